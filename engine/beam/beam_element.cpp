#include "engine/beam/beam_element.hpp"

#include "engine/math/rotation.hpp"
#include "engine/model/model.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>

namespace yarnsim {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

/// Quadratic Lagrange shape functions on xi in [-1, 1], nodes at -1, 0, 1.
Vector3d shape_at(double xi) {
  return {0.5 * xi * (xi - 1.0), 1.0 - xi * xi, 0.5 * xi * (xi + 1.0)};
}
Vector3d shape_derivative_at(double xi) {
  return {xi - 0.5, -2.0 * xi, xi + 0.5};
}

const double kGauss = 1.0 / std::sqrt(3.0);

/// Kinematic quantities of one Gauss point: x', alpha, alpha'.
struct GaussKinematics {
  Vector3d dx, alpha, dalpha;
};

GaussKinematics kinematics(const BeamReference& ref, const BeamNodalValues& v, int g) {
  return {v.x * ref.shape_derivative.col(g), v.alpha * ref.shape.col(g),
          v.alpha * ref.shape_derivative.col(g)};
}

/// Rodrigues factor g = 4 / (4 + alpha.alpha) and its first and second derivatives.
struct RodriguesFactor {
  double g;
  Vector3d dg;
  Matrix3d ddg;
  explicit RodriguesFactor(const Vector3d& a) {
    g = 4.0 / (4.0 + a.squaredNorm());
    dg = -0.5 * g * g * a;
    ddg = 0.5 * g * g * g * a * a.transpose() - 0.5 * g * g * Matrix3d::Identity();
  }
};

/// Derivatives of p(alpha) = Q(alpha)^T v and s(alpha) = Xi(alpha)^T w for fixed v, w, plus the
/// transposed first derivatives applied to given vectors. M(alpha) = -A + A^2/2, Q^T = I + g M;
/// S0(alpha) = I - A/2, Xi^T = g S0.
struct GaussEnergyTerms {
  Vector3d z, w;   // z = Q(alpha)^T x' - Q_n Gamma_0, w = Xi^T alpha' + kappa_n
  Vector3d nz, mw; // M_N z, M_M w
  Matrix3d dz;     // dz/dalpha (3 x 3), column k
  Matrix3d dw;     // dw/dalpha
};

} // namespace

BeamReference make_beam_reference(const Matrix3d& X, const Vector3d& reference_vector,
                                  const Section& section) {
  BeamReference ref;
  ref.C_N = Vector3d(section.GA1, section.GA2, section.EA).asDiagonal();
  ref.C_M << section.EI1, section.EI12, 0.0, section.EI12, section.EI2, 0.0, 0.0, 0.0, section.GJ;
  for (int g = 0; g < 2; ++g) {
    const double xi = g == 0 ? -kGauss : kGauss;
    const Vector3d dX = X * shape_derivative_at(xi);
    const double J = dX.norm();
    if (!(J > 0.0) || !std::isfinite(J))
      throw std::invalid_argument("beam element has zero length at a Gauss point");
    ref.shape.col(g) = shape_at(xi);
    ref.shape_derivative.col(g) = shape_derivative_at(xi) / J;
    ref.weight(g) = J; // Gauss weight 1
    ref.Q0[g] = triad_from(dX, reference_vector);
    ref.gamma0[g] = ref.Q0[g].transpose() * (dX / J);
  }
  return ref;
}

namespace {

/// Evaluates z, w, the energy density and (optionally) everything the gradient needs.
struct GaussPointEvaluation {
  double energy = 0;
  Vector3d grad_dx, grad_alpha, grad_dalpha; // de/dx', de/dalpha, de/dalpha'
  Matrix3d H_dx_dx, H_dx_a, H_da_da, H_da_a, H_a_a;
};

GaussPointEvaluation evaluate_gauss_point(const BeamReference& ref, const GaussState& h, int g,
                                          const GaussKinematics& k, bool want_hessian) {
  GaussPointEvaluation out;
  const Vector3d& a = k.alpha;
  const Vector3d& v = k.dx;
  const Vector3d& da = k.dalpha;
  const RodriguesFactor f(a);

  // p = Q^T x' = x' + g (-a x x' + 1/2 a x (a x x'))
  const Vector3d axv = a.cross(v);
  const Vector3d Mv = -axv + 0.5 * a.cross(axv);
  const Vector3d p = v + f.g * Mv;
  // s = Xi^T alpha' = g (alpha' - 1/2 a x alpha')
  const Vector3d S0da = da - 0.5 * a.cross(da);
  const Vector3d s = f.g * S0da;

  const Matrix3d& Qn = h.Q_n;
  const Vector3d z = p - Qn * ref.gamma0[g];
  const Vector3d w = s + h.kappa_n;
  const Matrix3d MN = Qn * ref.C_N * Qn.transpose();
  const Matrix3d MM = Qn * ref.C_M * Qn.transpose();
  const Vector3d nz = MN * z;
  const Vector3d mw = MM * w;
  out.energy = 0.5 * z.dot(nz) + 0.5 * w.dot(mw);

  // First derivatives of p and s with respect to alpha, column k.
  Matrix3d dp, ds;
  std::array<Vector3d, 3> dMv, dS0da;
  for (int c = 0; c < 3; ++c) {
    const Vector3d e = Vector3d::Unit(c);
    dMv[c] = -e.cross(v) + 0.5 * (e.cross(axv) + a.cross(e.cross(v)));
    dp.col(c) = f.dg(c) * Mv + f.g * dMv[c];
    dS0da[c] = -0.5 * e.cross(da);
    ds.col(c) = f.dg(c) * S0da + f.g * dS0da[c];
  }
  const Matrix3d Qa = rodrigues_rotation<double>(a); // = P^T
  const Matrix3d Xi = rodrigues_xi<double>(a);       // = S^T

  out.grad_dx = Qa * nz;
  out.grad_dalpha = Xi * mw;
  out.grad_alpha = dp.transpose() * nz + ds.transpose() * mw;
  if (!want_hessian)
    return out;

  out.H_dx_dx = Qa * MN * Qa.transpose();
  out.H_da_da = Xi * MM * Xi.transpose();
  // (d_k P)^T y = dg_k (a x y + 1/2 a x (a x y)) + g (e_k x y + 1/2 (a x (e_k x y) + e_k x (a x
  // y))) (d_k S)^T y = dg_k (y + 1/2 a x y) + g/2 e_k x y
  const Vector3d axnz = a.cross(nz);
  const Vector3d MTnz = axnz + 0.5 * a.cross(axnz);
  const Vector3d S0Tmw = mw + 0.5 * a.cross(mw);
  for (int c = 0; c < 3; ++c) {
    const Vector3d e = Vector3d::Unit(c);
    const Vector3d dMTnz = e.cross(nz) + 0.5 * (a.cross(e.cross(nz)) + e.cross(axnz));
    out.H_dx_a.col(c) = f.dg(c) * MTnz + f.g * dMTnz + Qa * (MN * dp.col(c));
    out.H_da_a.col(c) = f.dg(c) * S0Tmw + 0.5 * f.g * e.cross(mw) + Xi * (MM * ds.col(c));
  }
  // H_aa(k, l) = dp_k . MN dp_l + ddp_kl . nz + ds_k . MM ds_l + dds_kl . mw
  out.H_a_a = dp.transpose() * MN * dp + ds.transpose() * MM * ds;
  for (int kk = 0; kk < 3; ++kk) {
    const Vector3d ek = Vector3d::Unit(kk);
    for (int l = kk; l < 3; ++l) {
      const Vector3d el = Vector3d::Unit(l);
      const Vector3d ddMv = 0.5 * (ek.cross(el.cross(v)) + el.cross(ek.cross(v)));
      const Vector3d ddp = f.ddg(kk, l) * Mv + f.dg(kk) * dMv[l] + f.dg(l) * dMv[kk] + f.g * ddMv;
      const Vector3d dds = f.ddg(kk, l) * S0da + f.dg(kk) * dS0da[l] + f.dg(l) * dS0da[kk];
      const double extra = ddp.dot(nz) + dds.dot(mw);
      out.H_a_a(kk, l) += extra;
      if (l != kk)
        out.H_a_a(l, kk) += extra;
    }
  }
  return out;
}

} // namespace

void beam_internal_force(const BeamReference& ref, const std::array<GaussState, 2>& history,
                         const BeamNodalValues& values, ElementVector& force,
                         ElementMatrix* tangent) {
  force.setZero();
  if (tangent)
    tangent->setZero();
  for (int g = 0; g < 2; ++g) {
    const GaussKinematics k = kinematics(ref, values, g);
    const GaussPointEvaluation e = evaluate_gauss_point(ref, history[g], g, k, tangent != nullptr);
    const double W = ref.weight(g);
    const auto N = ref.shape.col(g);
    const auto dN = ref.shape_derivative.col(g);
    for (int i = 0; i < 3; ++i) {
      force.segment<3>(6 * i) += W * dN(i) * e.grad_dx;
      force.segment<3>(6 * i + 3) += W * (N(i) * e.grad_alpha + dN(i) * e.grad_dalpha);
    }
    if (!tangent)
      continue;
    ElementMatrix& K = *tangent;
    const Matrix3d H_a_da = e.H_da_a.transpose();
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        K.block<3, 3>(6 * i, 6 * j) += (W * dN(i) * dN(j)) * e.H_dx_dx;
        K.block<3, 3>(6 * i, 6 * j + 3) += (W * dN(i) * N(j)) * e.H_dx_a;
        K.block<3, 3>(6 * i + 3, 6 * j) += (W * N(i) * dN(j)) * e.H_dx_a.transpose();
        K.block<3, 3>(6 * i + 3, 6 * j + 3) +=
            W * (N(i) * N(j) * e.H_a_a + N(i) * dN(j) * H_a_da + dN(i) * N(j) * e.H_da_a +
                 dN(i) * dN(j) * e.H_da_da);
      }
    }
  }
}

double beam_strain_energy(const BeamReference& ref, const std::array<GaussState, 2>& history,
                          const BeamNodalValues& values) {
  double energy = 0;
  for (int g = 0; g < 2; ++g) {
    const GaussKinematics k = kinematics(ref, values, g);
    energy += ref.weight(g) * evaluate_gauss_point(ref, history[g], g, k, false).energy;
  }
  return energy;
}

Eigen::Matrix<double, 6, 2> beam_section_resultants(const BeamReference& ref,
                                                    const std::array<GaussState, 2>& history,
                                                    const BeamNodalValues& values) {
  Eigen::Matrix<double, 6, 2> out;
  for (int g = 0; g < 2; ++g) {
    const GaussKinematics k = kinematics(ref, values, g);
    const Matrix3d QnT = history[g].Q_n.transpose();
    const Vector3d gamma =
        QnT * (rodrigues_rotation<double>(k.alpha).transpose() * k.dx) - ref.gamma0[g];
    const Vector3d K =
        QnT * (rodrigues_xi<double>(k.alpha).transpose() * k.dalpha + history[g].kappa_n);
    out.col(g).head<3>() = ref.C_N * gamma;
    out.col(g).tail<3>() = ref.C_M * K;
  }
  return out;
}

std::array<GaussState, 2> beam_committed_history(const BeamReference& ref,
                                                 const std::array<GaussState, 2>& history,
                                                 const BeamNodalValues& values) {
  std::array<GaussState, 2> out;
  for (int g = 0; g < 2; ++g) {
    const GaussKinematics k = kinematics(ref, values, g);
    const Matrix3d Qa = rodrigues_rotation<double>(k.alpha);
    out[g].Q_n = orthonormalized(Qa * history[g].Q_n);
    out[g].kappa_n = rodrigues_xi<double>(k.alpha) * k.dalpha + Qa * history[g].kappa_n;
  }
  return out;
}

} // namespace yarnsim
