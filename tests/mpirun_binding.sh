#!/usr/bin/env bash
# scripts/mpirun leaves a job free to run on every CPU this shell may use: two single-rank
# studies started side by side must not both be pinned to core 0 (Open MPI's default for 1-2
# ranks), and CASSINI_BIND=core still pins. Usage: mpirun_binding.sh REPO
set -euo pipefail
repo=$1
allowed() { grep Cpus_allowed_list /proc/self/status | awk '{print $2}'; }
mine=$(allowed)
run() { "$repo/scripts/mpirun" -n 1 bash -c 'grep Cpus_allowed_list /proc/self/status' | awk '{print $2}'; }
got=$(run)
echo "this shell: $mine; a 1-rank job of scripts/mpirun: $got"
[ "$got" = "$mine" ] || { echo "FAIL: scripts/mpirun pinned the job to $got"; exit 1; }
if [ "$(nproc)" -gt 1 ]; then
  pinned=$(CASSINI_BIND=core run)
  echo "with CASSINI_BIND=core: $pinned"
  [ "$pinned" != "$mine" ] || { echo "FAIL: CASSINI_BIND=core did not pin"; exit 1; }
fi
echo PASS
