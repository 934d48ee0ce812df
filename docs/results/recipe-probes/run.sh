#!/bin/bash
# run.sh NAME MAP SEED STEPS [--set ...]: train the recipe base (path + shaping) plus the extra sets into NAME, then ev.sh. LEARNER: the binary (default learner on PATH); CONFIG: the base config (default the repo-relative tuned rm-2.1 IMPALA config).
L=${LEARNER:-learner}; C=${CONFIG:-learner/configs/impala-ctde-rm-2.1.toml}
name=$1; map=$2; seed=$3; steps=$4; shift 4
/usr/bin/time -f "$name wall %e s" $L train --config $C --map $map --seed $seed --steps $steps --set features.path=true --set shaping=0.05 "$@" --out $name --quiet > $name.log 2>&1
tail -n 2 $name.log
./ev.sh $name $map
