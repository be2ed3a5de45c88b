#include "parallel/MpiCounters.hpp"

#include <mpi.h>

namespace cassini::mpi_counters {
namespace {

Counts counts;

std::int64_t bytes(int count, MPI_Datatype type) {
  int size = 0;
  PMPI_Type_size(type, &size);
  return std::int64_t(count) * size;
}

void add(Kind k, std::int64_t b) {
  if (k != Send) ++collective_calls;
  ++counts.calls[k];
  counts.bytes[k] += b;
}

std::int64_t sum(const int* counts_of, MPI_Comm comm) {
  int n = 0;
  PMPI_Comm_size(comm, &n);
  std::int64_t s = 0;
  for (int r = 0; r < n; ++r) s += counts_of[r];
  return s;
}

}  // namespace

Counts now() { return counts; }

}  // namespace cassini::mpi_counters

using namespace cassini::mpi_counters;

// The entry points: count, then call the library's (PMPI_) version. Bytes are what this rank
// puts in (its send buffer), as a message-passing cost model wants them.
extern "C" {

int MPI_Allreduce(const void* s, void* r, int n, MPI_Datatype t, MPI_Op op, MPI_Comm c) {
  add(Allreduce, bytes(n, t));
  return PMPI_Allreduce(s, r, n, t, op, c);
}
int MPI_Iallreduce(const void* s, void* r, int n, MPI_Datatype t, MPI_Op op, MPI_Comm c, MPI_Request* req) {
  add(Allreduce, bytes(n, t));
  return PMPI_Iallreduce(s, r, n, t, op, c, req);
}
int MPI_Reduce(const void* s, void* r, int n, MPI_Datatype t, MPI_Op op, int root, MPI_Comm c) {
  add(Reduce, bytes(n, t));
  return PMPI_Reduce(s, r, n, t, op, root, c);
}
int MPI_Bcast(void* b, int n, MPI_Datatype t, int root, MPI_Comm c) {
  add(Bcast, bytes(n, t));
  return PMPI_Bcast(b, n, t, root, c);
}
int MPI_Barrier(MPI_Comm c) {
  add(Barrier, 0);
  return PMPI_Barrier(c);
}
int MPI_Allgather(const void* s, int sn, MPI_Datatype st, void* r, int rn, MPI_Datatype rt, MPI_Comm c) {
  add(Allgather, bytes(sn, st));
  return PMPI_Allgather(s, sn, st, r, rn, rt, c);
}
int MPI_Allgatherv(const void* s, int sn, MPI_Datatype st, void* r, const int rn[], const int d[], MPI_Datatype rt,
                   MPI_Comm c) {
  add(Allgather, bytes(sn, st));
  return PMPI_Allgatherv(s, sn, st, r, rn, d, rt, c);
}
int MPI_Alltoall(const void* s, int sn, MPI_Datatype st, void* r, int rn, MPI_Datatype rt, MPI_Comm c) {
  int n = 0;
  PMPI_Comm_size(c, &n);
  add(Alltoall, bytes(sn, st) * n);
  return PMPI_Alltoall(s, sn, st, r, rn, rt, c);
}
int MPI_Alltoallv(const void* s, const int sn[], const int sd[], MPI_Datatype st, void* r, const int rn[],
                  const int rd[], MPI_Datatype rt, MPI_Comm c) {
  add(Alltoall, bytes(1, st) * sum(sn, c));
  return PMPI_Alltoallv(s, sn, sd, st, r, rn, rd, rt, c);
}
int MPI_Gather(const void* s, int sn, MPI_Datatype st, void* r, int rn, MPI_Datatype rt, int root, MPI_Comm c) {
  add(Gather, bytes(sn, st));
  return PMPI_Gather(s, sn, st, r, rn, rt, root, c);
}
int MPI_Gatherv(const void* s, int sn, MPI_Datatype st, void* r, const int rn[], const int d[], MPI_Datatype rt,
                int root, MPI_Comm c) {
  add(Gather, bytes(sn, st));
  return PMPI_Gatherv(s, sn, st, r, rn, d, rt, root, c);
}
int MPI_Exscan(const void* s, void* r, int n, MPI_Datatype t, MPI_Op op, MPI_Comm c) {
  add(Scan, bytes(n, t));
  return PMPI_Exscan(s, r, n, t, op, c);
}
int MPI_Scan(const void* s, void* r, int n, MPI_Datatype t, MPI_Op op, MPI_Comm c) {
  add(Scan, bytes(n, t));
  return PMPI_Scan(s, r, n, t, op, c);
}
int MPI_Isend(const void* b, int n, MPI_Datatype t, int dest, int tag, MPI_Comm c, MPI_Request* req) {
  add(Send, bytes(n, t));
  return PMPI_Isend(b, n, t, dest, tag, c, req);
}
int MPI_Send(const void* b, int n, MPI_Datatype t, int dest, int tag, MPI_Comm c) {
  add(Send, bytes(n, t));
  return PMPI_Send(b, n, t, dest, tag, c);
}

}  // extern "C"
