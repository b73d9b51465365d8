#include "dist/transfer.hpp"

#include <algorithm>

namespace strata::dist {

namespace {
constexpr int kTag = 17;
constexpr std::uint64_t kPiece = 1ull << 30;  // bytes per message, within MPI's int counts
}  // namespace

int comm_rank(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

int comm_size(MPI_Comm comm) {
  int n = 1;
  MPI_Comm_size(comm, &n);
  return n;
}

void send_bytes(MPI_Comm comm, int to, const void* data, std::uint64_t size) {
  MPI_Send(&size, 1, MPI_UINT64_T, to, kTag, comm);
  const auto* bytes = static_cast<const std::byte*>(data);
  for (std::uint64_t at = 0; at < size; at += kPiece)
    MPI_Send(bytes + at, int(std::min(kPiece, size - at)), MPI_BYTE, to, kTag, comm);
}

std::uint64_t receive_size(MPI_Comm comm, int from) {
  std::uint64_t size = 0;
  MPI_Recv(&size, 1, MPI_UINT64_T, from, kTag, comm, MPI_STATUS_IGNORE);
  return size;
}

void receive_bytes(MPI_Comm comm, int from, void* data, std::uint64_t size) {
  auto* bytes = static_cast<std::byte*>(data);
  for (std::uint64_t at = 0; at < size; at += kPiece)
    MPI_Recv(bytes + at, int(std::min(kPiece, size - at)), MPI_BYTE, from, kTag, comm, MPI_STATUS_IGNORE);
}

}  // namespace strata::dist
