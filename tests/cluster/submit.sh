#!/usr/bin/env bash
# A stand-in for sbatch/qsub for the cluster-generic executor (tests/test_cluster_executor.py):
#
#   --cluster-generic-submit-cmd "bash tests/cluster/submit.sh LOG {rule} {threads} {resources.mem_mb} {resources.runtime} '{output}'"
#
# Snakemake appends the job script's path.  The script records the submission
# (one tab-separated line in LOG: job id, rule, threads, mem_mb, runtime,
# output files), starts the job script in the background in a session of its own
# (setsid; output in LOG's folder, <job id>.out) and prints the job id, as a
# scheduler's submit command does.  Job status comes from the executor's
# default: the job script touches a "finished" or "failed" marker.
set -euo pipefail
if [ "$#" -ne 7 ]; then
    echo "usage: submit.sh LOG RULE THREADS MEM_MB RUNTIME OUTPUT JOBSCRIPT (got $# arguments)" >&2
    exit 2
fi
log=$1 rule=$2 threads=$3 mem_mb=$4 runtime=$5 output=$6 jobscript=$7
id="job$(date +%s%N)-$$"
printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$id" "$rule" "$threads" "$mem_mb" "$runtime" "$output" >> "$log"
setsid bash "$jobscript" > "$(dirname "$log")/$id.out" 2>&1 < /dev/null &
echo "$id"
