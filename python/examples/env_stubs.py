"""Python stubs of Buridan's env API (``proto/proto/buridan/v1/env.proto``),
generated with grpcio-tools when first imported.

    from env_stubs import load
    pb2, pb2_grpc = load()          # pb2.StepRequest, pb2_grpc.EnvironmentStub, ...

The stubs are generated at run time into a temporary directory rather than
committed: env.proto stays the single source, so the example can never
serve an older copy of the API, and nothing generated lands in the
checkout. It costs about a tenth of a second per process and needs
``grpcio-tools`` (``python -m grpc_tools.protoc``, the same protoc as a
build step would run).

The proto is copied under the module name ``buridan_env_v1`` before
generating: protoc names modules after the file's path, and
``buridan/v1/env_pb2.py`` would be shadowed by (or shadow) the ``buridan``
package that ``pip install ./python`` installs. The wire names are
unchanged: the package statement, not the path, makes the service
``buridan.v1.Environment``.
"""

from __future__ import annotations

import atexit
import importlib
import os
import shutil
import sys
import tempfile
import threading
from pathlib import Path

# The checkout's copy; BURIDAN_ENV_PROTO points elsewhere (e.g. a copy
# shipped with a simulator outside this repository).
DEFAULT_PROTO = (
    Path(__file__).resolve().parents[2] / "proto" / "proto" / "buridan" / "v1" / "env.proto"
)
MODULE = "buridan_env_v1"

_lock = threading.Lock()
_loaded = None


def proto_path() -> Path:
    return Path(os.environ.get("BURIDAN_ENV_PROTO", DEFAULT_PROTO))


def load(proto: Path | str | None = None):
    """``(env_pb2, env_pb2_grpc)``, generated from ``proto`` (default: the
    checkout's env.proto) once per process."""
    global _loaded
    with _lock:
        if _loaded is None:
            _loaded = _generate(Path(proto) if proto else proto_path())
        return _loaded


def _generate(proto: Path):
    if not proto.is_file():
        raise FileNotFoundError(
            f"env.proto not found at {proto} (set BURIDAN_ENV_PROTO to its path)"
        )
    try:
        from grpc_tools import protoc
    except ImportError as e:
        raise ImportError(
            "generating the env API stubs needs grpcio-tools: pip install grpcio-tools"
        ) from e
    out = Path(tempfile.mkdtemp(prefix="buridan-env-stubs-"))
    atexit.register(shutil.rmtree, out, ignore_errors=True)
    pkg = out / MODULE
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    shutil.copyfile(proto, pkg / "env.proto")
    # protoc's own include dir, for well-known types should env.proto ever
    # import one.
    well_known = Path(protoc.__file__).parent / "_proto"
    args = [
        "grpc_tools.protoc",
        f"-I{out}",
        f"-I{well_known}",
        f"--python_out={out}",
        f"--grpc_python_out={out}",
        f"{MODULE}/env.proto",
    ]
    if protoc.main(args) != 0:
        raise RuntimeError(f"protoc failed on {proto} (its messages are above)")
    sys.path.insert(0, str(out))
    try:
        pb2 = importlib.import_module(f"{MODULE}.env_pb2")
        pb2_grpc = importlib.import_module(f"{MODULE}.env_pb2_grpc")
    finally:
        sys.path.remove(str(out))
    return pb2, pb2_grpc


if __name__ == "__main__":
    pb2, _ = load()
    print(pb2.DESCRIPTOR.services_by_name["Environment"].full_name, "from", proto_path())
