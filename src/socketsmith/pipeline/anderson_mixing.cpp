#include "socketsmith/pipeline/anderson_mixing.h"

#include <Eigen/Dense>

namespace socketsmith::pipeline {

std::vector<double> AndersonMixing::next(const std::vector<double>& x, const std::vector<double>& f) {
  const size_t n = x.size();
  x_.push_back(x);
  f_.push_back(f);
  if (static_cast<int>(x_.size()) > depth_ + 1) {
    x_.erase(x_.begin());
    f_.erase(f_.begin());
  }
  std::vector<double> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = x[i] + f[i];
  const int m = static_cast<int>(x_.size()) - 1;
  if (m < 1) return out;
  Eigen::MatrixXd dF(n, m), dX(n, m);
  Eigen::VectorXd fk = Eigen::Map<const Eigen::VectorXd>(f.data(), static_cast<Eigen::Index>(n));
  for (int j = 0; j < m; ++j)
    for (size_t i = 0; i < n; ++i) {
      dF(static_cast<Eigen::Index>(i), j) = f[i] - f_[j][i];
      dX(static_cast<Eigen::Index>(i), j) = x[i] - x_[j][i];
    }
  const Eigen::VectorXd theta = dF.colPivHouseholderQr().solve(fk);
  if (!theta.allFinite()) return out;
  const Eigen::VectorXd step = (dX + dF) * theta;
  for (size_t i = 0; i < n; ++i) out[i] -= step[static_cast<Eigen::Index>(i)];
  return out;
}

}  // namespace socketsmith::pipeline
