# keep SRC DST: each finished building's trials and summary of a run.sh folder (sourced by the study scripts)
keep() {
  [ -d $1 ] || return 0
  for d in $1/building_*/; do
    [ -e $d/trials.jsonl ] || continue  # a building cut before it finished
    mkdir -p $2/$(basename $d) && cp $d/trials.jsonl $d/summary.md $2/$(basename $d)/
  done
}
