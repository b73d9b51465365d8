#include "strata/dist/agree.hpp"

#include "dist/transfer.hpp"

namespace strata::dist {

void agree(MPI_Comm comm, std::exception_ptr error) {
  const int ranks = comm_size(comm), rank = comm_rank(comm);
  int first = error ? rank : ranks;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == ranks) return;
  if (rank == first) std::rethrow_exception(error);
  throw PeerFailure(first);
}

}  // namespace strata::dist
