// The module libcassini_cholmod.so: SuiteSparse's supernodal Cholesky behind SparseCholesky.
// Built apart from the core and loaded on first use (SparseCholesky.cpp), so that CHOLMOD's
// BLAS, LAPACK and Fortran runtime are mapped only into runs that solve a flow.
#include <Eigen/CholmodSupport>

#include "physics/channel/SparseCholesky.hpp"

namespace {

class SupernodalCholesky final : public cassini::SparseCholesky {
 public:
  void analyze(const Matrix& a) override { llt_.analyzePattern(a); }
  bool factorize(const Matrix& a) override {
    llt_.factorize(a);
    return llt_.info() == Eigen::Success;
  }
  Vector solve(const Vector& b) const override { return llt_.solve(b); }

 private:
  Eigen::CholmodSupernodalLLT<Matrix> llt_;
};

}  // namespace

extern "C" __attribute__((visibility("default"))) cassini::SparseCholesky* cassini_new_supernodal_cholesky_v1() {
  return new SupernodalCholesky();
}
