// Consistency of the beam kernel: tangent against finite differences of the residual, residual
// against finite differences of the energy, zero force under rigid motion.
#include "engine/beam/beam_element.hpp"
#include "engine/math/rotation.hpp"
#include "engine/model/model.hpp"

#include <gtest/gtest.h>
#include <random>

namespace yarnsim {
namespace {

Section test_section() {
  Section s;
  s.EA = 1e4;
  s.GA1 = 3e3;
  s.GA2 = 5e3;
  s.EI1 = 2.0;
  s.EI2 = 7.0;
  s.EI12 = 0.5;
  s.GJ = 3.0;
  return s;
}

/// A curved reference element of length about 1.
Eigen::Matrix3d curved_nodes() {
  Eigen::Matrix3d X;
  X.col(0) << 0.0, 0.0, 0.0;
  X.col(1) << 0.5, 0.1, 0.02;
  X.col(2) << 1.0, 0.05, -0.03;
  return X;
}

struct RandomState {
  BeamReference ref;
  std::array<GaussState, 2> history;
  BeamNodalValues values;
};

RandomState random_state(std::mt19937& rng, double alpha_scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Matrix3d X = curved_nodes();
  RandomState s{make_beam_reference(X, Eigen::Vector3d(0.2, 1.0, 0.3), test_section()), {}, {}};
  // A history far from the reference: rotations of several turns composed, nonzero curvature.
  for (int g = 0; g < 2; ++g) {
    const Eigen::Vector3d big(7.0 * u(rng), 7.0 * u(rng), 7.0 * u(rng)); // up to 12 rad
    s.history[g].Q_n = rotation_matrix(big) * s.ref.Q0[g];
    s.history[g].kappa_n = Eigen::Vector3d(u(rng), u(rng), u(rng));
  }
  for (int i = 0; i < 3; ++i) {
    s.values.x.col(i) = X.col(i) + 0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    s.values.alpha.col(i) = alpha_scale * Eigen::Vector3d(u(rng), u(rng), u(rng));
  }
  return s;
}

ElementVector force_at(const RandomState& s, const BeamNodalValues& v) {
  ElementVector f;
  beam_internal_force(s.ref, s.history, v, f, nullptr);
  return f;
}

BeamNodalValues perturbed(const BeamNodalValues& v, int dof, double h) {
  BeamNodalValues p = v;
  const int node = dof / 6, c = dof % 6;
  if (c < 3)
    p.x(c, node) += h;
  else
    p.alpha(c - 3, node) += h;
  return p;
}

TEST(BeamElement, TangentMatchesFiniteDifferencesAtRandomStatesBeyondPi) {
  std::mt19937 rng(42);
  for (int trial = 0; trial < 20; ++trial) {
    const RandomState s = random_state(rng, trial < 10 ? 0.5 : 2.0);
    ElementVector f;
    ElementMatrix K;
    beam_internal_force(s.ref, s.history, s.values, f, &K);
    const double h = 1e-6;
    ElementMatrix K_fd;
    for (int j = 0; j < 18; ++j)
      K_fd.col(j) =
          (force_at(s, perturbed(s.values, j, h)) - force_at(s, perturbed(s.values, j, -h))) /
          (2 * h);
    const double err = (K - K_fd).norm() / K_fd.norm();
    EXPECT_LT(err, 1e-6) << "trial " << trial;
    if (std::getenv("YARNSIM_DEBUG"))
      std::printf("trial %d err %.3e\n", trial, err);
    // The tangent is a Hessian of the strain energy, hence symmetric.
    EXPECT_LT((K - K.transpose()).norm() / K.norm(), 1e-12);
  }
}

TEST(BeamElement, ResidualIsTheGradientOfTheStrainEnergy) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 10; ++trial) {
    const RandomState s = random_state(rng, 1.0);
    const ElementVector f = force_at(s, s.values);
    ElementVector f_fd;
    const double h = 1e-6;
    for (int j = 0; j < 18; ++j)
      f_fd(j) = (beam_strain_energy(s.ref, s.history, perturbed(s.values, j, h)) -
                 beam_strain_energy(s.ref, s.history, perturbed(s.values, j, -h))) /
                (2 * h);
    EXPECT_LT((f - f_fd).norm() / f_fd.norm(), 1e-7) << "trial " << trial;
  }
}

/// A random nodal increment: translations and Rodrigues increments of order 0.1.
BeamNodalValues random_direction(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  BeamNodalValues d;
  for (int i = 0; i < 3; ++i) {
    d.x.col(i) = 0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    d.alpha.col(i) = 0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng));
  }
  return d;
}

BeamNodalValues along(const BeamNodalValues& v, const BeamNodalValues& d, double h) {
  return {v.x + h * d.x, v.alpha + h * d.alpha};
}

TEST(BeamElement, LinearisedStrainsAreTheStrainsDerivativeAlongTheIncrement) {
  // beam_strains' rate is B d, the mixed integration point Newton's strain increment.
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const RandomState s = random_state(rng, trial < 10 ? 0.5 : 2.0);
    const BeamNodalValues d = random_direction(rng);
    Eigen::Matrix<double, 6, 2> strain, rate, plus, minus, unused;
    beam_strains(s.ref, s.history, s.values, d, strain, rate);
    const double h = 1e-6;
    beam_strains(s.ref, s.history, along(s.values, d, h), d, plus, unused);
    beam_strains(s.ref, s.history, along(s.values, d, -h), d, minus, unused);
    const Eigen::Matrix<double, 6, 2> rate_fd = (plus - minus) / (2 * h);
    EXPECT_LT((rate - rate_fd).norm() / rate_fd.norm(), 1e-8) << "trial " << trial;
    // The strains are those of the section resultants.
    const Eigen::Matrix<double, 6, 2> resultants =
        beam_section_resultants(s.ref, s.history, s.values);
    EXPECT_LT((beam_resultants_of_strains(s.ref, strain) - resultants).norm() / resultants.norm(),
              1e-13)
        << "trial " << trial;
  }
}

TEST(BeamElement, MixedTangentTakesTheGivenResultantsInItsStressTerms) {
  // K(sigma) = sum_g W (B^T C B + G(sigma)), G(sigma) the Hessian of sum_g W sigma_g . eps_g(u)
  // at fixed sigma. So K(sigma) - K equals the Hessian of phi(u) = sum_g W (sigma_g - s_g) .
  // eps_g(u), s the current strains' resultants; its gradient is (B^T (sigma - s))_j, from
  // beam_strains' rate along each DOF, and its Hessian is taken by central differences.
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const RandomState s = random_state(rng, trial < 10 ? 0.5 : 2.0);
    ElementVector f, f_mixed;
    ElementMatrix K, K_same, K_mixed;
    beam_internal_force(s.ref, s.history, s.values, f, &K);
    const Eigen::Matrix<double, 6, 2> current = beam_section_resultants(s.ref, s.history, s.values);
    beam_internal_force(s.ref, s.history, s.values, f_mixed, &K_same, &current);
    EXPECT_LT((K_same - K).norm() / K.norm(), 1e-13) << "trial " << trial;
    // Resultants far from the current ones (forces of order EA 0.1, moments of order EI).
    const Eigen::Matrix<double, 6, 2> sigma =
        current + Eigen::Matrix<double, 6, 2>::Random().cwiseProduct(
                      (Eigen::Matrix<double, 6, 2>() << 3e2, 3e2, 3e2, 3e2, 1e3, 1e3, 2.0, 2.0, 2.0,
                       2.0, 2.0, 2.0)
                          .finished());
    beam_internal_force(s.ref, s.history, s.values, f_mixed, &K_mixed, &sigma);
    EXPECT_EQ(f_mixed, f) << "the force is the displacement-based one";
    const auto gradient_phi = [&](const BeamNodalValues& v) {
      ElementVector grad;
      for (int j = 0; j < 18; ++j) {
        BeamNodalValues unit{Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero()};
        if (j % 6 < 3)
          unit.x(j % 6, j / 6) = 1.0;
        else
          unit.alpha(j % 6 - 3, j / 6) = 1.0;
        Eigen::Matrix<double, 6, 2> strain, rate;
        beam_strains(s.ref, s.history, v, unit, strain, rate);
        grad(j) = s.ref.weight(0) * (sigma.col(0) - current.col(0)).dot(rate.col(0)) +
                  s.ref.weight(1) * (sigma.col(1) - current.col(1)).dot(rate.col(1));
      }
      return grad;
    };
    ElementMatrix G_fd;
    const double h = 1e-6;
    for (int j = 0; j < 18; ++j)
      G_fd.col(j) =
          (gradient_phi(perturbed(s.values, j, h)) - gradient_phi(perturbed(s.values, j, -h))) /
          (2 * h);
    const ElementMatrix G = K_mixed - K;
    EXPECT_LT((G - G_fd).norm() / G_fd.norm(), 1e-6) << "trial " << trial;
    EXPECT_GT(G.norm(), 1e-3 * K.norm()) << "the stress terms must matter in this test";
    EXPECT_LT((K_mixed - K_mixed.transpose()).norm() / K_mixed.norm(), 1e-12);
  }
}

TEST(BeamElement, RigidMotionOfACurvedBeamGivesNoInternalForce) {
  const Eigen::Matrix3d X = curved_nodes();
  const BeamReference ref = make_beam_reference(X, Eigen::Vector3d(0, 1, 0), test_section());
  std::array<GaussState, 2> history{GaussState{ref.Q0[0], Eigen::Vector3d::Zero()},
                                    GaussState{ref.Q0[1], Eigen::Vector3d::Zero()}};
  BeamNodalValues v{X, Eigen::Matrix3d::Zero()};
  // Ten steps of a large rigid rotation (total about 9 rad about a skew axis) and a translation.
  const Eigen::Vector3d step_rotation = Eigen::Vector3d(0.3, -0.5, 0.8).normalized() * 0.9;
  const Eigen::Matrix3d R = rotation_matrix(step_rotation);
  const Eigen::Vector3d alpha = rodrigues_of(R);
  Eigen::Matrix3d x = X;
  for (int step = 0; step < 10; ++step) {
    for (int i = 0; i < 3; ++i)
      x.col(i) = R * x.col(i) + Eigen::Vector3d(1.0, -2.0, 0.5);
    v.x = x;
    v.alpha = alpha.replicate<1, 3>();
    ElementVector f;
    beam_internal_force(ref, history, v, f, nullptr);
    EXPECT_LT(f.norm(), 1e-9) << "step " << step;
    history = beam_committed_history(ref, history, v);
  }
}

TEST(Rotation, RodriguesIdentities) {
  const Eigen::Vector3d a(0.7, -1.3, 2.1);
  const Eigen::Matrix3d Q = rodrigues_rotation<double>(a);
  const Eigen::Matrix3d Xi = rodrigues_xi<double>(a);
  EXPECT_LT((Q.transpose() * Q - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_LT((Q.transpose() * Xi - Xi.transpose()).norm(), 1e-14);
  EXPECT_LT((rotation_matrix(rotation_vector_of_rodrigues<double>(a)) - Q).norm(), 1e-13);
  EXPECT_LT((rodrigues_of(Q) - a).norm(), 1e-12);
  // The Rodrigues parameters of a rotation vector, on both sides of the small-angle series.
  EXPECT_LT((rodrigues_of_vector(rotation_vector_of_rodrigues<double>(a)) - a).norm(), 1e-12);
  const Eigen::Vector3d tiny(3e-7, -2e-7, 1e-7);
  EXPECT_LT((rodrigues_rotation<double>(rodrigues_of_vector(tiny)) - rotation_matrix(tiny)).norm(),
            1e-15);
  // Spin of a varying parameter: skew(Xi da) = dQ Q^T.
  const Eigen::Vector3d da(0.3, 0.1, -0.2);
  const double h = 1e-6;
  const Eigen::Matrix3d dQ = (rodrigues_rotation<double>(Eigen::Vector3d(a + h * da)) -
                              rodrigues_rotation<double>(Eigen::Vector3d(a - h * da))) /
                             (2 * h);
  EXPECT_LT((axial(dQ * Q.transpose()) - Xi * da).norm(), 1e-8);
}

} // namespace
} // namespace yarnsim
