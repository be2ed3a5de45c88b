#pragma once
// A sparse symmetric positive definite factorisation, as the Stokes solve uses it (analyse a
// pattern once, factorise each new operator, solve many right-hand sides).
//
// Two kinds: Eigen's simplicial LLT (in the core; bitwise repeatable, the `repeatable` solve)
// and SuiteSparse's supernodal CHOLMOD (10x faster on 3D grids). CHOLMOD and the BLAS, LAPACK
// and Fortran runtime it needs live in a module, libcassini_cholmod.so, loaded on the first
// supernodal factorisation: scenes without a flow never load them (~2.8 MB resident per rank).
// The module's one symbol, cassini_new_supernodal_cholesky_v1, carries this class's version:
// change the class, bump the suffix, so that an older executable refuses a newer module.
#include <memory>

#include <Eigen/SparseCore>

namespace cassini {

class SparseCholesky {
 public:
  using Matrix = Eigen::SparseMatrix<double>;
  using Vector = Eigen::VectorXd;
  virtual ~SparseCholesky() = default;
  virtual void analyze(const Matrix& a) = 0;
  // false where the matrix is not positive definite
  virtual bool factorize(const Matrix& a) = 0;
  virtual Vector solve(const Vector& b) const = 0;
};

// SparseCholesky over one of Eigen's LLT types (SimplicialLLT here, CholmodSupernodalLLT in the module).
template <class LLT>
class EigenCholesky final : public SparseCholesky {
 public:
  void analyze(const Matrix& a) override { llt_.analyzePattern(a); }
  bool factorize(const Matrix& a) override {
    llt_.factorize(a);
    return llt_.info() == Eigen::Success;
  }
  Vector solve(const Vector& b) const override { return llt_.solve(b); }

 private:
  LLT llt_;
};

std::unique_ptr<SparseCholesky> make_simplicial_cholesky();
// Loads the module (from $CASSINI_MODULE_DIR if set, else beside the executable, one folder up,
// or in the build folder); throws with the paths tried if it is missing.
std::unique_ptr<SparseCholesky> make_supernodal_cholesky();

}  // namespace cassini
