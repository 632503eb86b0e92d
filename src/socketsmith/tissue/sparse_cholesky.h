#pragma once
/// @file sparse_cholesky.h
/// The sparse Cholesky factorisation every solver of socketsmith uses — the static solve's
/// preconditioner, the implicit step, the design solver's rest and tangent factors, contact
/// Newton: CHOLMOD's supernodal LLᵀ of a symmetric positive definite matrix, of which only the
/// triangle @p UpLo is read. One holder, so the three things every solver needs are done once:
///  - the fill-reducing ordering (CHOLMOD: AMD, then METIS when AMD fills too much; on the 8k
///    stump METIS's factor has 4.8 M entries against AMD's 6.7 M) is computed only when the
///    matrix's pattern changed: a Newton loop whose tangent keeps its pattern pays it once;
///  - OpenBLAS runs single-threaded and the OpenMP regions CHOLMOD opens run on the calling
///    thread (limit_solver_threads, SerialParallelRegions: both measured faster on these meshes);
///    the solvers' own loops get the free cores (limit_solver_threads);
///  - factorisations are counted for the solvers' reports.

#include <algorithm>

#include <Eigen/CholmodSupport>

#include "socketsmith/core/log.h"
#include "socketsmith/tissue/static_solver.h"

namespace socketsmith::tissue {

/// While alive, every OpenMP parallel region runs on the calling thread alone. CHOLMOD's supernodal
/// factorisation opens a region per supernode asking for 4 threads, each of which asked the kernel
/// for the load and the affinity and woke the pool (with OpenMP's dynamic teams: a 7.5k-node
/// donning made 209k sysinfo + sched_getaffinity and 814k futex calls, ≈ 10 % of its CPU in the
/// kernel, strace -c / perf), for loops too small to share.
class SerialParallelRegions {
 public:
  // Out of line (static_solver.cpp, in the tissue module, which is built with OpenMP): inline,
  // a translation unit built without OpenMP (a benchmark, a module without it) compiled them to
  // nothing, and CHOLMOD's regions then started a thread team per supernode there.
  SerialParallelRegions();
  ~SerialParallelRegions();
  SerialParallelRegions(const SerialParallelRegions&) = delete;
  SerialParallelRegions& operator=(const SerialParallelRegions&) = delete;

 private:
  int levels_ = 1;
};

/// @tparam UpLo the triangle read (Eigen::Lower or Eigen::Upper). CHOLMOD permutes an upper-stored
/// matrix with one transpose, a lower-stored one with two.
template <int UpLo = Eigen::Lower>
class SparseCholesky {
 public:
  /// CHOLMOD's supernodes relaxed twice as far as its defaults (nrelax 8/32/96 columns, zrelax
  /// 0.95/0.2/0.1 of explicit zeros): larger dense blocks for dgemm. On the 7.7k-node stump's
  /// tangent (17k dofs) a factorisation takes ≈ 12 % less time on average, faster in 10 of 12
  /// back-to-back pairs (`BM_StumpTangent`); three or four times as far gained nothing more.
  ///
  /// CHOLMOD's own messages ("CHOLMOD warning: matrix not positive definite", which every solver
  /// handles by a fallback) went to stdout through printf, in the middle of `--json` output; they
  /// go to the debug log instead.
  SparseCholesky() {
    auto& c = llt_.cholmod();
    c.print = 0;
    c.error_handler = [](int status, const char* file, int line, const char* message) {
      log::debug("CHOLMOD {} {}: {} ({}:{})", status < 0 ? "error" : "warning", status, message, file, line);
    };
    for (int i = 0; i < 3; ++i) {
      c.nrelax[i] *= 2;
      c.zrelax[i] = std::min(0.95, 2.0 * c.zrelax[i]);
    }
  }
  /// Factorises @p A + @p shift I (A square, symmetric in the triangle read). The ordering is
  /// recomputed when A's size or its number of stored entries changed since the last call (the
  /// matrices socketsmith assembles keep their pattern as long as both stay the same). False when
  /// the matrix is not positive definite: the factor is then not valid.
  bool factorize(const SparseMatrix& A, double shift = 0.0) {
    limit_solver_threads();
    const SerialParallelRegions serial;
    if (A.rows() != rows_ || A.nonZeros() != nnz_) {
      llt_.analyzePattern(A);
      rows_ = A.rows();
      nnz_ = A.nonZeros();
    }
    llt_.setShift(shift);
    llt_.factorize(A);
    valid_ = llt_.info() == Eigen::Success;
    if (valid_) ++factorizations_;
    return valid_;
  }
  /// A⁻¹ b (one back-substitution per column of @p b) with the last valid factor.
  template <class Rhs>
  Eigen::Matrix<double, Eigen::Dynamic, Rhs::ColsAtCompileTime> solve(const Eigen::MatrixBase<Rhs>& b) const {
    const SerialParallelRegions serial;
    return llt_.solve(b);
  }
  bool valid() const { return valid_; }
  /// Marks the factor as out of date (its matrix changed); the ordering is kept.
  void invalidate() { valid_ = false; }
  /// Successful factorisations since construction.
  long factorizations() const { return factorizations_; }

 private:
  Eigen::CholmodSupernodalLLT<SparseMatrix, UpLo> llt_;
  Eigen::Index rows_ = -1, nnz_ = -1;
  bool valid_ = false;
  long factorizations_ = 0;
};

}  // namespace socketsmith::tissue
