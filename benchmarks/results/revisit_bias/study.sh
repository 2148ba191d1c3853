#!/usr/bin/env bash
# plan.md: keep the trials of val.sh and test.sh in runs/, then the figures (study_zero_shot.py, pooled over every
# building finished): validation (the rule) and the held-out intervention, each against EM and against the
# shipped actor alone (--reference-policy learned).
set -e
HERE=$(cd "$(dirname "$0")" && pwd)
PY=${PY:-/work/main/.venv/bin/python}
STUDY=$HERE/../../study_zero_shot.py
ZS=$HERE/../zero_shot_buildings_100/runs  # EM's and the shipped actor's trials of the held-out buildings
source $HERE/../keep.sh  # keep SRC DST [PARITY]
# validation: a building counts once both runs of it finished
for d in /work/runs/rb_val/biased/building_*/; do
  b=$(basename $d)
  [ -e $d/trials.jsonl ] && [ -e /work/runs/rb_val/pair/$b/trials.jsonl ] || continue
  mkdir -p $HERE/runs/val_pair/$b $HERE/runs/val_biased/$b
  cp /work/runs/rb_val/pair/$b/{trials.jsonl,summary.md} $HERE/runs/val_pair/$b/
  cp $d/{trials.jsonl,summary.md} $HERE/runs/val_biased/$b/
done
# the exploratory dose-response (plan.md addendum), where it ran: the buildings with the pair finished too
for d in /work/runs/rb_val/dose/building_*/; do
  b=$(basename $d)
  [ -e $d/trials.jsonl ] && [ -e /work/runs/rb_val/pair/$b/trials.jsonl ] || continue
  mkdir -p $HERE/runs/val_dose/$b && cp $d/{trials.jsonl,summary.md} $HERE/runs/val_dose/$b/
done
for s in even odd; do keep /work/runs/rb_dose_test/$s $HERE/runs/dose_test/$s; done
keep /work/runs/rb_test $HERE/runs/test/even even
keep /work/runs/rb_test $HERE/runs/test/odd odd
V=$HERE/runs
$PY $STUDY $V/val_pair --pool val_shipped --out $HERE/targets_val_shipped > $HERE/study_val_shipped.log
$PY $STUDY $V/val_biased --reference $V/val_pair --pool val_biased --out $HERE/targets_val_biased \
  > $HERE/study_val_biased.log
$PY $STUDY $V/val_biased --reference $V/val_pair --reference-policy learned --pool val_direct \
  --out $HERE/targets_val_direct > $HERE/direct_val.log
$PY $STUDY $V/test/even $V/test/odd --reference $ZS/even $ZS/odd --pool test_biased --out $HERE/targets_test \
  > $HERE/study_test.log
$PY $STUDY $V/test/even $V/test/odd --reference $ZS/even $ZS/odd --reference-policy learned --pool test_direct \
  --out $HERE/targets_test_direct > $HERE/direct_test.log
if [ -d $V/val_dose ]; then
  $PY $STUDY $V/val_dose --reference $V/val_pair --pool val_dose --out $HERE/targets_val_dose > $HERE/study_val_dose.log
  $PY $STUDY $V/val_dose --reference $V/val_pair --reference-policy learned --pool val_dose_direct \
    --out $HERE/targets_val_dose_direct > $HERE/direct_val_dose.log
fi
for run in /work/runs/rb_sweep_*_val; do  # session 42's validation sweep (sweep.sh): one folder per b
  [ -d $run ] || continue
  name=val_sweep_$(basename $run | sed 's/rb_sweep_//; s/_val$//')
  keep $run $V/$name
  $PY $STUDY $V/$name --reference $V/val_pair --pool $name --out $HERE/targets_$name > $HERE/study_$name.log
  $PY $STUDY $V/$name --reference $V/val_pair --reference-policy learned --pool ${name}_direct \
    --out $HERE/targets_${name}_direct > $HERE/direct_$name.log
done
for run in /work/runs/rb_sweep_*_test; do  # and the held-out run of the value it adopts, where it ran
  [ -d $run ] || continue
  name=test_sweep_$(basename $run | sed 's/rb_sweep_//; s/_test$//')
  keep $run $V/$name/even even
  keep $run $V/$name/odd odd
  $PY $STUDY $V/$name/even $V/$name/odd --reference $ZS/even $ZS/odd --pool $name --out $HERE/targets_$name \
    > $HERE/study_$name.log
  $PY $STUDY $V/$name/even $V/$name/odd --reference $ZS/even $ZS/odd --reference-policy learned \
    --pool ${name}_direct --out $HERE/targets_${name}_direct > $HERE/direct_$name.log
done
if [ -d $V/dose_test ]; then  # the held-out dose-response (second addendum): against EM, and the actor alone
  $PY $STUDY $V/dose_test/even $V/dose_test/odd --reference $ZS/even $ZS/odd --pool dose_test \
    --out $HERE/targets_dose_test > $HERE/study_dose_test.log
  $PY $STUDY $V/dose_test/even $V/dose_test/odd --reference $ZS/even $ZS/odd --reference-policy learned \
    --pool dose_test_direct --out $HERE/targets_dose_test_direct > $HERE/direct_dose_test.log
fi
