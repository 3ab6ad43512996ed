# Shared by the MPI tests: mpirun as CI runs it (as root, in a container, on 2 cores: three
# processes oversubscribe them), and a 12 x 12 weave deck made from the paper's 6 x 6.
# OpenMPI makes oversubscribed processes yield while they wait by itself; asking for it always
# (mpi_yield_when_idle = 1) made 2 processes sharing the cores with other work 50 times slower.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1       # more processes than cores
export OMPI_MCA_btl_vader_single_copy_mechanism=none # containers: no cross-memory attach
export OPENBLAS_NUM_THREADS=1

source "$(dirname "${BASH_SOURCE[0]}")/../cli/lib/results.sh"
source "$(dirname "${BASH_SOURCE[0]}")/../cli/lib/decks.sh"

# mpirun -np N yarnsim ARGS...
mpi() { # N args...
  local n="$1"; shift
  mpirun -np "$n" "$yarnsim" "$@"
}

# The paper's deck with n x n yarns, the yarns 3 spacings longer than the fabric's width.
weave_deck() { # n file
  local n="$1" length
  length=$(awk -v n="$n" 'BEGIN { printf "%.9g", (n + 3) * 4.54545e-3 }')
  sed -e "s/^n_warp = .*/n_warp = $n/; s/^n_weft = .*/n_weft = $n/" \
    -e "s/^length_warp = .*/length_warp = $length/; s/^length_weft = .*/length_weft = $length/" \
    "$repo/examples/biaxial-k1.toml" > "$2"
}
