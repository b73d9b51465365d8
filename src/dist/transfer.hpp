#pragma once
// Point-to-point transfers between the ranks of the distributed drivers (compress.cpp,
// labels.cpp): arrays of any size, sent as their byte count and then in pieces MPI's int counts
// can hold. Sender and receiver must agree on the element type; transfers between two ranks
// arrive in the order they were sent (one tag).
#include <mpi.h>

#include <cstdint>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "strata/core/error.hpp"

namespace strata::dist {

int comm_rank(MPI_Comm comm);
int comm_size(MPI_Comm comm);

void send_bytes(MPI_Comm comm, int to, const void* data, std::uint64_t size);
std::uint64_t receive_size(MPI_Comm comm, int from);
void receive_bytes(MPI_Comm comm, int from, void* data, std::uint64_t size);

template <class T>
void send_array(MPI_Comm comm, int to, std::span<const T> values) {
  static_assert(std::is_trivially_copyable_v<T>);
  send_bytes(comm, to, values.data(), values.size_bytes());
}

template <class T>
std::vector<T> receive_array(MPI_Comm comm, int from) {
  static_assert(std::is_trivially_copyable_v<T>);
  const std::uint64_t size = receive_size(comm, from);
  if (size % sizeof(T) != 0)
    throw Error("rank " + std::to_string(from) + " sent " + std::to_string(size) + " bytes, not whole elements of " +
                std::to_string(sizeof(T)) + " bytes");
  std::vector<T> values(std::size_t(size / sizeof(T)));
  receive_bytes(comm, from, values.data(), size);
  return values;
}

/// Collective: every rank's `value` on rank 0, in rank order; the others get their own only.
template <class T>
std::vector<T> gather_to_root(MPI_Comm comm, const T& value) {
  static_assert(std::is_trivially_copyable_v<T>);
  const bool root = comm_rank(comm) == 0;
  std::vector<T> all(root ? std::size_t(comm_size(comm)) : 1, value);
  MPI_Gather(&value, int(sizeof value), MPI_BYTE, root ? all.data() : nullptr, int(sizeof value), MPI_BYTE, 0, comm);
  return all;
}

}  // namespace strata::dist
