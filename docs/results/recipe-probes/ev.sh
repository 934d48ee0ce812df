#!/bin/bash
# ev.sh RUN MAP [AGENTS] -> prints success for greedy, sampled, shield greedy
L=${LEARNER:-learner}
run=$1; map=$2; ag=${3:-4}
ck=$(ls -d $run/checkpoints/* | sort | tail -n 1)
for spec in "g checkpoint:$ck" "s checkpoint:$ck --sample" "sh shield:checkpoint:$ck"; do
  set -- $spec; tag=$1; shift
  out=$run/eval-$map-$ag-$tag
  $L eval --map $map --agents $ag --episodes 100 --seed 42 --controller "$@" --out $out --json 2>/dev/null > $out.json
  python3 -c "import json,sys;d=json.load(open('$out.json'));d=d[0] if isinstance(d,list) else d;print('$run $map $ag $tag', round(100*d['success_rate'],1) if 'success_rate' in d else {k:v for k,v in d.items() if 'succ' in k})"
done
