#include "engine/beam/beam_element.hpp"

#include "engine/math/rotation.hpp"
#include "engine/model/model.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>
#include <unsupported/Eigen/AutoDiff>

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

// The Gauss-point kernel evaluates both Gauss points at once: every quantity is a Pair of doubles,
// lane g for Gauss point g, so each arithmetic instruction serves both points (SSE2 packets on
// x86-64, GCC/Clang vector extension). Eigen's packets on 3- and 9-element objects instead stored
// scalars and reloaded them as pairs; the stalled store-to-load forwarding cost a third of the
// kernel's time (perf, bench_beam). The operations and their order are those of scalar code.
using Pair = double __attribute__((vector_size(16)));

struct Vec {
  Pair c[3];
  Pair operator[](int i) const { return c[i]; }
  Pair& operator[](int i) { return c[i]; }
};
struct Mat {
  Pair m[9]; ///< row-major
  Pair operator()(int i, int j) const { return m[3 * i + j]; }
  Pair& operator()(int i, int j) { return m[3 * i + j]; }
};

inline Vec operator+(const Vec& a, const Vec& b) {
  return {{a[0] + b[0], a[1] + b[1], a[2] + b[2]}};
}
inline Vec operator-(const Vec& a, const Vec& b) {
  return {{a[0] - b[0], a[1] - b[1], a[2] - b[2]}};
}
inline Vec operator*(Pair s, const Vec& a) {
  return {{s * a[0], s * a[1], s * a[2]}};
}
inline Vec operator*(double s, const Vec& a) {
  return {{s * a[0], s * a[1], s * a[2]}};
}
inline Pair dot(const Vec& a, const Vec& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline Vec cross(const Vec& a, const Vec& b) {
  return {{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}};
}
/// Lane g from u[g].
inline Vec pair_of(const Eigen::Vector3d& u0, const Eigen::Vector3d& u1) {
  return {{Pair{u0(0), u1(0)}, Pair{u0(1), u1(1)}, Pair{u0(2), u1(2)}}};
}
inline Mat pair_of(const Eigen::Matrix3d& A0, const Eigen::Matrix3d& A1) {
  Mat r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r(i, j) = Pair{A0(i, j), A1(i, j)};
  return r;
}
/// M v
inline Vec mul(const Mat& M, const Vec& v) {
  Vec r;
  for (int i = 0; i < 3; ++i)
    r[i] = M(i, 0) * v[0] + M(i, 1) * v[1] + M(i, 2) * v[2];
  return r;
}
/// M^T v
inline Vec mul_t(const Mat& M, const Vec& v) {
  Vec r;
  for (int j = 0; j < 3; ++j)
    r[j] = M(0, j) * v[0] + M(1, j) * v[1] + M(2, j) * v[2];
  return r;
}
/// A B
inline Mat mul(const Mat& A, const Mat& B) {
  Mat r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r(i, j) = A(i, 0) * B(0, j) + A(i, 1) * B(1, j) + A(i, 2) * B(2, j);
  return r;
}
/// A^T B, for a symmetric result: the upper triangle is computed and mirrored.
inline Mat mul_t_sym(const Mat& A, const Mat& B) {
  Mat r;
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j)
      r(j, i) = r(i, j) = A(0, i) * B(0, j) + A(1, i) * B(1, j) + A(2, i) * B(2, j);
  return r;
}
/// A B^T, for a symmetric result.
inline Mat mul_sym_t(const Mat& A, const Mat& B) {
  Mat r;
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j)
      r(j, i) = r(i, j) = A(i, 0) * B(j, 0) + A(i, 1) * B(j, 1) + A(i, 2) * B(j, 2);
  return r;
}
/// s skew(v) added to M.
inline void add_skew(Mat& M, Pair s, const Vec& v) {
  M(0, 1) -= s * v[2];
  M(0, 2) += s * v[1];
  M(1, 0) += s * v[2];
  M(1, 2) -= s * v[0];
  M(2, 0) -= s * v[1];
  M(2, 1) += s * v[0];
}

/// The residual's quantities at the two Gauss points, in closed form. With a = alpha, v = x',
/// A = skew(a), g = 4 / (4 + a.a) (rotation.hpp):
///   p = Q(a)^T v = v + g Mv,       Mv   = -a x v + 1/2 (a (a.v) - (a.a) v)
///   s = Xi(a)^T a' = g S0a',       S0a' = a' - 1/2 a x a'
///   Gamma = Q_n^T p - Gamma_0,  K = Q_n^T (s + kappa_n)   (material strain and curvature)
///   nz = Q_n C_N Gamma,  mw = Q_n C_M K                   (spatial force N, moment N m)
///   de/dx' = Q nz,  de/da' = Xi mw,  de/da = (Mv.nz + S0a'.mw) dg/da + g r
///   r = dMv/da^T nz + dS0a'/da^T mw
///     = nz x v + 1/2 ((a.v) nz + (a.nz) v) - (v.nz) a + 1/2 mw x a'
/// with dg/da = -g^2 a / 2. C_N is diagonal (make_beam_reference).
struct GaussPoints {
  Vec a, v, da; // alpha, x' (-), alpha' (1/m)
  Pair aa, g;
  Vec dg;       // dg/dalpha
  Vec Mv, S0da; // p = v + g Mv, s = g S0da
  Vec nz, mw;
  Vec r;
  Pair c;      // Mv.nz + S0da.mw
  Pair energy; // J/m
  Vec grad_dx, grad_alpha, grad_dalpha;

  GaussPoints(const BeamReference& ref, const std::array<GaussState, 2>& h,
              const BeamNodalValues& values) {
    const Pair N[3] = {Pair{ref.shape(0, 0), ref.shape(0, 1)},
                       Pair{ref.shape(1, 0), ref.shape(1, 1)},
                       Pair{ref.shape(2, 0), ref.shape(2, 1)}};
    const Pair dN[3] = {Pair{ref.shape_derivative(0, 0), ref.shape_derivative(0, 1)},
                        Pair{ref.shape_derivative(1, 0), ref.shape_derivative(1, 1)},
                        Pair{ref.shape_derivative(2, 0), ref.shape_derivative(2, 1)}};
    for (int k = 0; k < 3; ++k) {
      a[k] = values.alpha(k, 0) * N[0] + values.alpha(k, 1) * N[1] + values.alpha(k, 2) * N[2];
      v[k] = values.x(k, 0) * dN[0] + values.x(k, 1) * dN[1] + values.x(k, 2) * dN[2];
      da[k] = values.alpha(k, 0) * dN[0] + values.alpha(k, 1) * dN[1] + values.alpha(k, 2) * dN[2];
    }
    aa = dot(a, a);
    g = 4.0 / (4.0 + aa);
    dg = (-0.5 * g * g) * a;
    const Pair av = dot(a, v);
    Mv = cross(v, a) + 0.5 * (av * a - aa * v);
    S0da = da - 0.5 * cross(a, da);
    const Mat Qn = pair_of(h[0].Q_n, h[1].Q_n);
    const Vec gamma = mul_t(Qn, v + g * Mv) - pair_of(ref.gamma0[0], ref.gamma0[1]);
    const Vec K = mul_t(Qn, g * S0da + pair_of(h[0].kappa_n, h[1].kappa_n));
    const Vec n{{ref.C_N(0, 0) * gamma[0], ref.C_N(1, 1) * gamma[1], ref.C_N(2, 2) * gamma[2]}};
    Vec m;
    for (int i = 0; i < 3; ++i)
      m[i] = ref.C_M(i, 0) * K[0] + ref.C_M(i, 1) * K[1] + ref.C_M(i, 2) * K[2];
    nz = mul(Qn, n);
    mw = mul(Qn, m);
    energy = 0.5 * dot(gamma, n) + 0.5 * dot(K, m);
    const Pair anz = dot(a, nz);
    grad_dx = nz + g * (cross(a, nz) + 0.5 * (anz * a - aa * nz));
    grad_dalpha = g * (mw + 0.5 * cross(a, mw));
    r = cross(nz, v) + 0.5 * (av * nz + anz * v) - dot(v, nz) * a + 0.5 * cross(mw, da);
    c = dot(Mv, nz) + dot(S0da, mw);
    grad_alpha = c * dg + g * r;
  }

  /// The same Gauss points with the spatial resultants nz, mw (and r, c, which are linear in
  /// them) of the material resultants `stress` (rows 0-2 forces N, 3-5 moments N m, columns the
  /// Gauss points) instead of those of the current strains: the stress terms of the mixed
  /// integration point tangent (beam_internal_force). The gradients are left as they are.
  GaussPoints with_resultants(const std::array<GaussState, 2>& h,
                              const Eigen::Matrix<double, 6, 2>& stress) const {
    GaussPoints out = *this;
    const Mat Qn = pair_of(h[0].Q_n, h[1].Q_n);
    Vec n, m;
    for (int i = 0; i < 3; ++i) {
      n[i] = Pair{stress(i, 0), stress(i, 1)};
      m[i] = Pair{stress(3 + i, 0), stress(3 + i, 1)};
    }
    out.nz = mul(Qn, n);
    out.mw = mul(Qn, m);
    const Pair av = dot(a, v);
    const Pair anz = dot(a, out.nz);
    out.r = cross(out.nz, v) + 0.5 * (av * out.nz + anz * v) - dot(v, out.nz) * a +
            0.5 * cross(out.mw, da);
    out.c = dot(Mv, out.nz) + dot(S0da, out.mw);
    return out;
  }
};

/// Second derivatives of the energy density at the two Gauss points with respect to (x', alpha,
/// alpha'); H_dx_da is zero. M_N = Q_n C_N Q_n^T, M_M = Q_n C_M Q_n^T. Closed forms, y a fixed
/// vector:
///   d(Q y)/da  = (A y + A^2 y / 2) dg^T + g (-skew(y) + 1/2 ((a.y) I + a y^T) - y a^T)
///   d(Xi y)/da = (y + a x y / 2) dg^T - g/2 skew(y)
///   dp/da = Mv dg^T + g (skew(v) + 1/2 ((a.v) I + a v^T) - v a^T)
///   ds/da = S0a' dg^T + g/2 skew(a')
///   H_x'x'  = Q M_N Q^T,   H_a'a' = Xi M_M Xi^T
///   H_x'a   = d(Q y)/da|y=nz + Q M_N dp/da,   H_a'a = d(Xi y)/da|y=mw + Xi M_M ds/da
///   H_aa  = dp^T M_N dp + ds^T M_M ds + c d2g + dg r^T + r dg^T
///           + g (1/2 (nz v^T + v nz^T) - (nz.v) I),   d2g = g^3 a a^T / 2 - g^2 I / 2
struct GaussHessians {
  Mat H_dx_dx, H_dx_a, H_da_a, H_da_da, H_a_a;

  GaussHessians(const BeamReference& ref, const std::array<GaussState, 2>& h,
                const GaussPoints& q) {
    const Vec& a = q.a;
    const Vec& v = q.v;
    const Vec& nz = q.nz;
    const Vec& mw = q.mw;
    const Pair g = q.g;
    const Mat Qn = pair_of(h[0].Q_n, h[1].Q_n);
    // M_N (diagonal C_N) and M_M, symmetric.
    Mat QnCN, QnCM;
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) {
        QnCN(i, k) = Qn(i, k) * ref.C_N(k, k);
        QnCM(i, k) = Qn(i, 0) * ref.C_M(0, k) + Qn(i, 1) * ref.C_M(1, k) + Qn(i, 2) * ref.C_M(2, k);
      }
    const Mat MN = mul_sym_t(QnCN, Qn);
    const Mat MM = mul_sym_t(QnCM, Qn);

    Mat Q, Xi;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        Q(i, j) = 0.5 * g * a[i] * a[j];
        Xi(i, j) = Pair{};
      }
    for (int i = 0; i < 3; ++i) {
      Q(i, i) += 1.0 - 0.5 * g * q.aa;
      Xi(i, i) = g;
    }
    add_skew(Q, g, a);
    add_skew(Xi, 0.5 * g, a);

    // dp/da and ds/da.
    const Pair av = dot(a, v);
    Mat dp, ds;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        dp(i, j) = q.Mv[i] * q.dg[j] + g * (0.5 * a[i] * v[j] - v[i] * a[j]);
        ds(i, j) = q.S0da[i] * q.dg[j];
      }
    for (int i = 0; i < 3; ++i)
      dp(i, i) += 0.5 * g * av;
    add_skew(dp, g, v);
    add_skew(ds, 0.5 * g, q.da);

    const Mat QMN = mul(Q, MN);
    const Mat XiMM = mul(Xi, MM);
    H_dx_dx = mul_sym_t(QMN, Q);
    H_da_da = mul_sym_t(XiMM, Xi);
    const Mat MNdp = mul(MN, dp);
    const Mat MMds = mul(MM, ds);
    const Mat QMNdp = mul(QMN, dp);
    const Mat XiMMds = mul(XiMM, ds);

    const Pair anz = dot(a, nz);
    const Vec MTnz = cross(a, nz) + 0.5 * (anz * a - q.aa * nz);
    const Vec Xmw = mw + 0.5 * cross(a, mw);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        H_dx_a(i, j) = MTnz[i] * q.dg[j] + g * (0.5 * a[i] * nz[j] - nz[i] * a[j]) + QMNdp(i, j);
        H_da_a(i, j) = Xmw[i] * q.dg[j] + XiMMds(i, j);
      }
    for (int i = 0; i < 3; ++i)
      H_dx_a(i, i) += 0.5 * g * anz;
    add_skew(H_dx_a, -g, nz);
    add_skew(H_da_a, -0.5 * g, mw);

    const Mat pMp = mul_t_sym(dp, MNdp);
    const Mat sMs = mul_t_sym(ds, MMds);
    const Pair caa = 0.5 * g * g * g * q.c;
    const Pair diag = -0.5 * g * g * q.c - g * dot(nz, v);
    for (int i = 0; i < 3; ++i)
      for (int j = i; j < 3; ++j)
        H_a_a(j, i) = H_a_a(i, j) = pMp(i, j) + sMs(i, j) + caa * a[i] * a[j] + q.dg[i] * q.r[j] +
                                    q.r[i] * q.dg[j] + 0.5 * g * (nz[i] * v[j] + v[i] * nz[j]);
    for (int i = 0; i < 3; ++i)
      H_a_a(i, i) += diag;
  }
};

/// Sum of the two lanes: the Gauss quadrature.
inline double sum(Pair p) {
  return p[0] + p[1];
}

} // namespace

void beam_internal_force(const BeamReference& ref, const std::array<GaussState, 2>& history,
                         const BeamNodalValues& values, ElementVector& force,
                         ElementMatrix* tangent, const Eigen::Matrix<double, 6, 2>* stress) {
  const GaussPoints q(ref, history, values);
  // Weight times N_i and N'_i, lane g for Gauss point g.
  Pair WN[3], WdN[3];
  for (int i = 0; i < 3; ++i) {
    WN[i] = Pair{ref.weight(0) * ref.shape(i, 0), ref.weight(1) * ref.shape(i, 1)};
    WdN[i] = Pair{ref.weight(0) * ref.shape_derivative(i, 0),
                  ref.weight(1) * ref.shape_derivative(i, 1)};
  }
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) {
      force(6 * i + k) = sum(WdN[i] * q.grad_dx[k]);
      force(6 * i + 3 + k) = sum(WN[i] * q.grad_alpha[k] + WdN[i] * q.grad_dalpha[k]);
    }
  if (!tangent)
    return;

  // K = sum_g W B_g^T H_g B_g with B_g mapping node (u_j, alpha_j) to (N'_j u_j, N_j alpha_j,
  // N'_j alpha_j). Both Gauss points are summed per 6 x 6 node block; the blocks below the
  // diagonal are the transposes of those above (K is a Hessian).
  const GaussHessians H(ref, history, stress ? q.with_resultants(history, *stress) : q);
  ElementMatrix& K = *tangent;
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) {
      const Pair N_j{ref.shape(j, 0), ref.shape(j, 1)};
      const Pair dN_j{ref.shape_derivative(j, 0), ref.shape_derivative(j, 1)};
      const Pair c_uu = WdN[i] * dN_j, c_ua = WdN[i] * N_j, c_au = WN[i] * dN_j, c_aa = WN[i] * N_j;
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) {
          const double uu = sum(c_uu * H.H_dx_dx(r, s));
          const double ua = sum(c_ua * H.H_dx_a(r, s));
          const double au = sum(c_au * H.H_dx_a(s, r));
          const double aa = sum(c_aa * H.H_a_a(r, s) + c_au * H.H_da_a(s, r) +
                                c_ua * H.H_da_a(r, s) + c_uu * H.H_da_da(r, s));
          K(6 * i + r, 6 * j + s) = uu;
          K(6 * i + r, 6 * j + 3 + s) = ua;
          K(6 * i + 3 + r, 6 * j + s) = au;
          K(6 * i + 3 + r, 6 * j + 3 + s) = aa;
          K(6 * j + s, 6 * i + r) = uu;
          K(6 * j + 3 + s, 6 * i + r) = ua;
          K(6 * j + s, 6 * i + 3 + r) = au;
          K(6 * j + 3 + s, 6 * i + 3 + r) = aa;
        }
    }
}

double beam_strain_energy(const BeamReference& ref, const std::array<GaussState, 2>& history,
                          const BeamNodalValues& values) {
  const GaussPoints q(ref, history, values);
  return ref.weight(0) * q.energy[0] + ref.weight(1) * q.energy[1];
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

void beam_strains(const BeamReference& ref, const std::array<GaussState, 2>& history,
                  const BeamNodalValues& values, const BeamNodalValues& direction,
                  Eigen::Matrix<double, 6, 2>& strain, Eigen::Matrix<double, 6, 2>& rate) {
  // Forward mode along `direction`: x', alpha and alpha' are linear in the nodal values, so the
  // derivative of the strains at values + h direction at h = 0 is B direction exactly.
  using Dual = Eigen::AutoDiffScalar<Eigen::Matrix<double, 1, 1>>;
  const auto dual = [](const Vector3d& value, const Vector3d& derivative) {
    Vec3<Dual> out;
    for (int i = 0; i < 3; ++i)
      out(i) = Dual(value(i), Eigen::Matrix<double, 1, 1>(derivative(i)));
    return out;
  };
  for (int g = 0; g < 2; ++g) {
    const GaussKinematics k = kinematics(ref, values, g);
    const GaussKinematics d = kinematics(ref, direction, g);
    const Vec3<Dual> dx = dual(k.dx, d.dx), alpha = dual(k.alpha, d.alpha),
                     dalpha = dual(k.dalpha, d.dalpha);
    const Mat3<Dual> QnT = history[g].Q_n.transpose().cast<Dual>();
    const Vec3<Dual> gamma =
        QnT * (rodrigues_rotation<Dual>(alpha).transpose() * dx) - ref.gamma0[g].cast<Dual>();
    const Vec3<Dual> K =
        QnT * (rodrigues_xi<Dual>(alpha).transpose() * dalpha + history[g].kappa_n.cast<Dual>());
    for (int i = 0; i < 3; ++i) {
      strain(i, g) = gamma(i).value();
      strain(3 + i, g) = K(i).value();
      rate(i, g) = gamma(i).derivatives()(0);
      rate(3 + i, g) = K(i).derivatives()(0);
    }
  }
}

Eigen::Matrix<double, 6, 2> beam_resultants_of_strains(const BeamReference& ref,
                                                       const Eigen::Matrix<double, 6, 2>& strain) {
  Eigen::Matrix<double, 6, 2> out;
  out.topRows<3>() = ref.C_N * strain.topRows<3>();
  out.bottomRows<3>() = ref.C_M * strain.bottomRows<3>();
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
