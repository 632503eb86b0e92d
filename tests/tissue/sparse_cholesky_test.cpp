// The one sparse Cholesky holder (sparse_cholesky.h): its solutions against a dense LLᵀ of the
// same matrix, a matrix that is not positive definite refused and the factor left invalid, the
// diagonal shift, CHOLMOD's messages kept off stdout, and a new pattern (another size) ordered
// again instead of reusing the old one.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstdio>
#include <string>
#include <thread>

#include <dlfcn.h>

#include "socketsmith/tissue/sparse_cholesky.h"

namespace socketsmith::tissue {
namespace {

/// The 1-D Laplacian of n nodes with both ends held (tridiagonal 2, −1) times @p scale, plus @p diag.
SparseMatrix laplacian(int n, double scale = 1.0, double diag = 0.0) {
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0 * scale + diag);
    if (i + 1 < n) {
      t.emplace_back(i, i + 1, -scale);
      t.emplace_back(i + 1, i, -scale);
    }
  }
  SparseMatrix A(n, n);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

template <int UpLo>
void expect_solves_like_dense(SparseCholesky<UpLo>& chol, const SparseMatrix& A, double shift = 0.0) {
  const Eigen::MatrixXd dense = Eigen::MatrixXd(A) + shift * Eigen::MatrixXd::Identity(A.rows(), A.cols());
  const VectorXd b = VectorXd::LinSpaced(A.rows(), -1.0, 2.0);
  const VectorXd x = chol.solve(b);
  EXPECT_LT((x - dense.llt().solve(b)).norm(), 1e-10 * x.norm());
  // Several right-hand sides at once (contact Newton's free-obstacle column beside the residual).
  Eigen::MatrixXd B(A.rows(), 2);
  B << b, VectorXd::Ones(A.rows());
  EXPECT_LT((chol.solve(B) - dense.llt().solve(B)).norm(), 1e-10 * B.norm());
}

TEST(SparseCholesky, solves_like_a_dense_cholesky_reading_either_triangle) {
  const SparseMatrix A = laplacian(40, 3e4);
  SparseCholesky<Eigen::Lower> lower;
  SparseCholesky<Eigen::Upper> upper;
  EXPECT_FALSE(lower.valid());
  ASSERT_TRUE(lower.factorize(A));
  ASSERT_TRUE(upper.factorize(A));
  EXPECT_TRUE(lower.valid());
  expect_solves_like_dense(lower, A);
  expect_solves_like_dense(upper, A);
  // The same pattern with other values: factorised again (the ordering kept), and counted.
  ASSERT_TRUE(lower.factorize(laplacian(40, 5.0, 1.0)));
  expect_solves_like_dense(lower, laplacian(40, 5.0, 1.0));
  EXPECT_EQ(lower.factorizations(), 2);
}

TEST(SparseCholesky, refuses_a_matrix_that_is_not_positive_definite_and_is_then_invalid) {
  SparseCholesky<> chol;
  ASSERT_TRUE(chol.factorize(laplacian(20)));
  EXPECT_FALSE(chol.factorize(laplacian(20, -1.0)));  // negative definite
  EXPECT_FALSE(chol.valid());
  EXPECT_EQ(chol.factorizations(), 1);
  // A shift makes a semi-definite matrix (the Laplacian with free ends: a rigid mode) definite.
  SparseMatrix free_ends = laplacian(20);
  free_ends.coeffRef(0, 0) = 1.0;
  free_ends.coeffRef(19, 19) = 1.0;
  EXPECT_FALSE(chol.factorize(free_ends));
  ASSERT_TRUE(chol.factorize(free_ends, 1e-3));
  expect_solves_like_dense(chol, free_ends, 1e-3);
  chol.invalidate();
  EXPECT_FALSE(chol.valid());
}

TEST(SparseCholesky, says_nothing_on_stdout_when_it_refuses_a_matrix) {
  // CHOLMOD printed "CHOLMOD warning: matrix not positive definite" with printf, into the JSON
  // that `validate design --json` writes on stdout.
  SparseCholesky<> chol;
  testing::internal::CaptureStdout();
  const bool ok = chol.factorize(laplacian(20, -1.0));
  std::fflush(stdout);
  const std::string out = testing::internal::GetCapturedStdout();
  EXPECT_FALSE(ok);
  EXPECT_EQ(out, "");
}

TEST(SparseCholesky, orders_a_matrix_of_another_pattern_again) {
  SparseCholesky<> chol;
  ASSERT_TRUE(chol.factorize(laplacian(30)));
  // Another size: reusing the old ordering would fail or solve a wrong system.
  ASSERT_TRUE(chol.factorize(laplacian(45, 2.0)));
  expect_solves_like_dense(chol, laplacian(45, 2.0));
  // Back to the first size, and a pattern with more entries at the same size.
  ASSERT_TRUE(chol.factorize(laplacian(30)));
  expect_solves_like_dense(chol, laplacian(30));
  SparseMatrix wider = laplacian(30);
  for (int i = 0; i + 2 < 30; ++i) {  // 2 − 2 cos θ + 0.2 cos 2θ ≥ 0.2: still positive definite
    wider.coeffRef(i, i + 2) = 0.1;
    wider.coeffRef(i + 2, i) = 0.1;
  }
  wider.makeCompressed();
  ASSERT_TRUE(chol.factorize(wider));
  expect_solves_like_dense(chol, wider);
}

/// An OpenMP runtime function of the library's (the tests are built without OpenMP).
template <class F>
F omp(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_DEFAULT, name));
}

TEST(SolverThreads, teams_are_fixed_never_more_than_the_cores_or_the_threads_own_limit) {
  // OpenMP's dynamic teams count the solve's own thread as load (one thread on 2 cores, always):
  // the solvers size their teams themselves, within the cores and the limit the thread had.
  const auto get_dynamic = omp<int (*)()>("omp_get_dynamic");
  const auto max_threads = omp<int (*)()>("omp_get_max_threads");
  const auto num_procs = omp<int (*)()>("omp_get_num_procs");
  const auto set_threads = omp<void (*)(int)>("omp_set_num_threads");
  if (!get_dynamic || !max_threads || !num_procs || !set_threads) GTEST_SKIP() << "built without OpenMP";
  std::thread([&] {
    limit_solver_threads();
    EXPECT_EQ(get_dynamic(), 0);
    EXPECT_GE(max_threads(), 1);
    EXPECT_LE(max_threads(), num_procs());
  }).join();
  std::thread([&] {  // a thread limited to one (the GUI's worker) stays at one
    set_threads(1);
    limit_solver_threads();
    EXPECT_EQ(max_threads(), 1);
    limit_solver_threads();
    EXPECT_EQ(max_threads(), 1);
  }).join();
}

TEST(SolverThreads, serial_parallel_regions_hold_in_a_unit_built_without_openmp) {
  // This test is built without OpenMP, like the benchmarks: an inline SerialParallelRegions
  // compiled to nothing here, and CHOLMOD then opened a thread team per supernode (the benchmark's
  // factorisations 170–290 ms instead of 94–115).
  const auto get_levels = omp<int (*)()>("omp_get_max_active_levels");
  if (!get_levels) GTEST_SKIP() << "built without OpenMP";
  std::thread([&] {
    const int before = get_levels();
    ASSERT_GT(before, 0);
    {
      const SerialParallelRegions serial;
      EXPECT_EQ(get_levels(), 0);
    }
    EXPECT_EQ(get_levels(), before);
  }).join();
}

}  // namespace
}  // namespace socketsmith::tissue
