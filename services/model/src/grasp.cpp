#include "tandem/model/grasp.hpp"

#include <algorithm>

#include <Eigen/Dense>

namespace tandem::model {

Mat3 skew(const Vec3& r) noexcept {
  Mat3 S;
  S << 0.0, -r(2), r(1), r(2), 0.0, -r(0), -r(1), r(0), 0.0;
  return S;
}

Mat6 stick_transform(const Vec3& r) noexcept {
  Mat6 W = Mat6::Identity();
  W.block<3, 3>(3, 0) = -skew(r);  // eq. (8)
  return W;
}

Mat6x12 grasp_matrix(const Vec3& r1, const Vec3& r2) noexcept {
  Mat6x12 W;
  W << stick_transform(r1), stick_transform(r2);  // eq. (9)
  return W;
}

Mat12x6 grasp_pseudo_inverse(const Mat6x12& W) noexcept {
  const Mat6 WWt = W * W.transpose();
  return W.transpose() * WWt.llt().solve(Mat6::Identity());  // eq. (10)
}

Mat12x6 grasp_null_space(const Mat6x12& W) noexcept {
  // Projector onto the null space, then an orthonormal basis of its range.
  const Eigen::Matrix<double, 12, 12> P =
      Eigen::Matrix<double, 12, 12>::Identity() - grasp_pseudo_inverse(W) * W;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> eig(P);
  // Eigenvalues are 0 (x6) and 1 (x6), sorted ascending: the last six vectors span the null space.
  return eig.eigenvectors().rightCols<6>();
}

Eigen::Matrix<double, 2, 4> planar_grasp_matrix() noexcept {
  Eigen::Matrix<double, 2, 4> W;
  W << Mat2::Identity(), Mat2::Identity();  // eq. (18)
  return W;
}

Eigen::Matrix<double, 4, 2> planar_grasp_pseudo_inverse() noexcept {
  Eigen::Matrix<double, 4, 2> Wp;
  Wp << 0.5 * Mat2::Identity(), 0.5 * Mat2::Identity();  // eq. (18)
  return Wp;
}

double stop_deceleration_bound(double h_ref, double h_sg, double mass, double mu_s, double g0) noexcept {
  const double normal = (h_ref - h_sg) / mass;
  const double faces = 2.0 * mu_s * h_ref / mass - g0;
  return std::max(0.0, std::min(normal, faces));
}

double safe_grasp_force(double mass, double mu_s, double g0) noexcept {
  return mass * g0 / (2.0 * mu_s);  // eq. (16)
}

Vec3 absolute_pose(const Vec3& tip1, const Vec3& tip2) noexcept {
  // eq. (11), on the continuous (unwrapped) joint-sum angles.
  return 0.5 * (tip1 + tip2);
}

Vec3 relative_pose(const Vec3& tip1, const Vec3& tip2) noexcept {
  return tip2 - tip1;  // eq. (12), on the continuous (unwrapped) joint-sum angles
}

}  // namespace tandem::model
