#!/usr/bin/env bash
# mpirun with the settings of the MPI tests (lib.sh): runs PROGRAM on N processes.
# Usage: mpirun.sh N PROGRAM [ARG ...]
set -u
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
n="$1"; shift
exec mpirun -np "$n" "$@"
