#pragma once
// How the ranks of the distributed drivers leave together when one fails: every collective step
// ends with agree(), so no rank waits in a later collective for one that has thrown.
#include <mpi.h>

#include <exception>
#include <string>

#include "strata/core/error.hpp"

namespace strata::dist {

/// @brief Thrown on the ranks that did not fail when another one did: that rank (the lowest
/// that failed) rethrows its own error, which is the one to report.
class PeerFailure : public Error {
 public:
  explicit PeerFailure(int rank) : Error("rank " + std::to_string(rank) + " failed"), rank_(rank) {}
  int rank() const { return rank_; }

 private:
  int rank_;
};

/// @brief Collective: every rank of `comm` passes what it caught (null when nothing). When some
/// rank failed, the lowest such rank rethrows its error and every other rank throws PeerFailure,
/// so all ranks leave together and none waits in a later collective.
void agree(MPI_Comm comm, std::exception_ptr error);

/// @brief Collective: runs `step` on this rank, then agree()s on whether any rank's step threw.
template <class Step>
void agree_on(MPI_Comm comm, Step&& step) {
  std::exception_ptr error;
  try {
    step();
  } catch (...) {
    error = std::current_exception();
  }
  agree(comm, error);
}

}  // namespace strata::dist
