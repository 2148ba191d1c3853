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

# vs_em_and_actor HERE NAME "REPORTS" "REFERENCES": study_zero_shot.py of the learned trials in REPORTS against EM's
# (HERE/study_NAME.log, HERE/targets_NAME) and against the shipped actor's (HERE/direct_NAME.log,
# HERE/targets_NAME_direct) trials in REFERENCES, paired by building
vs_em_and_actor() {
  $PY $RESULTS/../study_zero_shot.py $3 --reference $4 --pool $2 --out $1/targets_$2 > $1/study_$2.log
  $PY $RESULTS/../study_zero_shot.py $3 --reference $4 --reference-policy learned --pool ${2}_direct \
    --out $1/targets_${2}_direct > $1/direct_$2.log
}

# val_study SRC HERE NAME: keep SRC's validation trials (stakes_distill/run.sh, SET=val) in HERE/runs/NAME, then
# vs_em_and_actor against the same config's trials (revisit_bias/runs/val_pair)
val_study() {
  keep $1 $2/runs/$3
  vs_em_and_actor $2 $3 $2/runs/$3 $RESULTS/revisit_bias/runs/val_pair
}

# self_vs HERE RUNS REFERENCE NAME: EM and the learned policy of RUNS each against its own trials in REFERENCE
# (study_zero_shot.py --policy P --reference-policy P): HERE/P_NAME.log and HERE/targets_P_NAME
self_vs() {
  for policy in em learned; do
    $PY $RESULTS/../study_zero_shot.py $2 --policy $policy --reference $3 --reference-policy $policy \
      --pool ${policy}_$4 --out $1/targets_${policy}_$4 > $1/${policy}_$4.log
  done
}

# in_repo_niced: for a long collection or fine-tune beside other runs, work from the repository with one BLAS thread
# per process and PY at nice 5 (icp_s65.sh, dagger_s71.sh)
in_repo_niced() {
  cd $RESULTS/../..
  export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
  PY="nice -n 5 .venv/bin/python"
}

# run_stages "KNOWN" STAGE...: a plan's stages in the order given, each a function stage_NAME of the calling script;
# every name is checked against KNOWN before any stage runs (a typo costs nothing), and each stage's start and end
# times (UTC) go to stdout
run_stages() {
  local known=$1 stage; shift
  for stage in "$@"; do
    case " $known " in *" $stage "*) ;; *) echo "unknown stage $stage (${known// /, })" >&2; exit 2;; esac
  done
  for stage in "$@"; do
    echo "$stage start $(date -u +%H:%M:%S)"
    stage_$stage
    echo "$stage end $(date -u +%H:%M:%S)"
  done
}

# stop85 KEY=VALUE...: keyframes_45deg/run.sh with the stop-85 config of every held-out pool and validation run
# (slam=icp, a 600 m travel budget, graph.max_nodes=4096) and the given run.sh settings (POLICIES, FIRST, LAST, OUT,
# EXTRA)
stop85() { env SLAM=icp BUDGET=600 MAX_NODES=4096 "$@" bash $RESULTS/keyframes_45deg/run.sh; }

# garage_like_lots FIRST LAST KIND [EXTRA]: the learned policy (with EXTRA's overrides) on session 70's garage-like lots
# FIRST-LAST in the stop-85 config (lots_s69.sh), into /work/runs/stop85_KIND_learned (study.sh's glotsX_val90 sets)
garage_like_lots() {
  SIZE=[28,32] LANE=[2.0,4.5] PITCH=[5.5,6.5] GAP=0.05 POLICIES=[learned] FIRST=$1 LAST=$2 \
    OUT=/work/runs/stop85_$3_learned EXTRA="${4:-}" bash $RESULTS/stop_coverage/lots_s69.sh
}

# split_by_reference SPLIT TRIALS RUNS REF...: TRIALS's buildings (a runs folder of building_SEED/) linked into
# SPLIT/REF for each reference folder RUNS/REF that has the same building, one report folder per reference, as
# study_zero_shot.py --reference pairs them (direct.sh, stop_coverage/noise_floor_s75.sh)
split_by_reference() {
  local split=$1 trials=$2 runs=$3 ref d b; shift 3
  for ref in "$@"; do
    mkdir -p $split/$ref
    for d in $runs/$ref/building_*/; do
      b=$(basename $d)
      [ -e $trials/$b/trials.jsonl ] && ln -s $trials/$b $split/$ref/$b
    done
  done
  return 0
}
