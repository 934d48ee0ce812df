# A probe's tool, not part of the product: copies a checkpoint with its logits head scaled.
# sharpen.py SRC_CKPT DST_CKPT K : copies a checkpoint, multiplying the logits head (weight, bias) by K
import json, struct, sys, shutil, os, array
src, dst, k = sys.argv[1], sys.argv[2], float(sys.argv[3])
shutil.copytree(src, dst)
p = os.path.join(dst, "model.safetensors")
raw = open(p, "rb").read()
n = struct.unpack("<Q", raw[:8])[0]
header = json.loads(raw[8:8 + n])
data = bytearray(raw[8 + n:])
names = []
for name, meta in header.items():
    if name == "__metadata__" or not name.split(".")[-2].endswith("logits"):
        continue
    assert meta["dtype"] == "F32"
    a, b = meta["data_offsets"]
    arr = array.array("f"); arr.frombytes(bytes(data[a:b]))
    arr = array.array("f", (x * k for x in arr))
    data[a:b] = arr.tobytes()
    names.append(name)
open(p, "wb").write(raw[:8 + n] + bytes(data))
print("scaled", names)
