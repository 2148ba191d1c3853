# Shared by the study scripts (sourced). PY: the Python to run (default: the repo's venv).
RESULTS=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
PY=${PY:-$RESULTS/../../.venv/bin/python}

# keep SRC DST [PARITY]: each finished building's trials and summary of a run or sweep folder (its *building_SEED
# folders; PARITY even/odd: those seeds only)
keep() {
  [ -d $1 ] || return 0
  for d in $1/*building_*/; do
    [ -e $d/trials.jsonl ] || continue  # a building cut before it finished
    seed=${d%/}; seed=${seed##*_}
    case ${3:-all} in even) [ $((seed % 2)) -eq 0 ] || continue;; odd) [ $((seed % 2)) -eq 1 ] || continue;; esac
    mkdir -p $2/$(basename $d) && cp $d/trials.jsonl $d/summary.md $2/$(basename $d)/
  done
}

# val_study SRC HERE NAME: keep SRC's validation trials (stakes_distill/run.sh, SET=val) in HERE/runs/NAME, then
# study_zero_shot.py against EM's (HERE/study_NAME.log) and the shipped actor's (HERE/direct_NAME.log) trials of
# the same config (revisit_bias/runs/val_pair)
val_study() {
  local pair=$RESULTS/revisit_bias/runs/val_pair
  keep $1 $2/runs/$3
  $PY $RESULTS/../study_zero_shot.py $2/runs/$3 --reference $pair --pool $3 --out $2/targets_$3 > $2/study_$3.log
  $PY $RESULTS/../study_zero_shot.py $2/runs/$3 --reference $pair --reference-policy learned --pool ${3}_direct \
    --out $2/targets_${3}_direct > $2/direct_$3.log
}

# self_vs HERE RUNS REFERENCE NAME: EM and the learned policy of RUNS each against its own trials in REFERENCE
# (study_zero_shot.py --policy P --reference-policy P): HERE/P_NAME.log and HERE/targets_P_NAME
self_vs() {
  for policy in em learned; do
    $PY $RESULTS/../study_zero_shot.py $2 --policy $policy --reference $3 --reference-policy $policy \
      --pool ${policy}_$4 --out $1/targets_${policy}_$4 > $1/${policy}_$4.log
  done
}
