// The module libcassini_cholmod.so: SuiteSparse's supernodal Cholesky behind SparseCholesky.
// Built apart from the core and loaded on first use (SparseCholesky.cpp), so that CHOLMOD's
// BLAS, LAPACK and Fortran runtime are mapped only into runs that solve a flow.
#include <Eigen/CholmodSupport>

#include "physics/channel/SparseCholesky.hpp"

extern "C" __attribute__((visibility("default"))) cassini::SparseCholesky* cassini_new_supernodal_cholesky_v1() {
  return new cassini::EigenCholesky<Eigen::CholmodSupernodalLLT<cassini::SparseCholesky::Matrix>>();
}
