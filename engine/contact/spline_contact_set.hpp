#pragma once
// The beam-to-beam spline contact stage (formulation.md §5): candidate segment pairs of the C1
// quadratic contact splines from the FCL-backed search, closest-point projections in parallel,
// assembly of the active pairs' 18 x 18 translational blocks in sorted order.

#include "broadphase/candidate_search.hpp"
#include "contact/interface_law.hpp"
#include "contact/spline_contact.hpp"
#include "contact/spline_curve.hpp"
#include "engine/contact/contact_set.hpp"

#include <Eigen/Core>
#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace yarnsim {

/// Normal law of a contact definition (linear, power, optionally damped).
std::shared_ptr<const contact::InterfaceLaw> make_interface_law(const InterfaceLawParameters& p);

class SplineContactSet final : public ContactSet {
public:
  explicit SplineContactSet(const Model& model);
  ~SplineContactSet() override;

  bool empty() const { return definitions_.empty(); }

  bool update_candidates(const State& state) override;
  std::string project(const State& state, bool want_tangent) override;
  int candidates_version() const override { return candidates_version_; }
  /// The 6 control points of each candidate pair.
  std::vector<std::array<int, 6>> couplings() const override;
  /// Translations only: the splines' control points carry no rotations.
  void assemble(Eigen::VectorXd& residual, Assembler& assembler, bool want_tangent) const override;
  void commit() override;
  /// Gaps are effective gaps (eq. 12).
  const ContactSummary& summary() const override { return summary_; }
  std::vector<ContactPoint> points() const override;

private:
  struct Definition;
  struct Work {
    int definition;
    broadphase::CandidatePair pair;
    contact::SplineContactResult result;
  };
  using Key = std::array<int, 3>; ///< definition, first, second segment id

  std::array<int, 6> nodes_of(const Definition& d, const broadphase::CandidatePair& p) const;

  const Model& model_;
  std::vector<contact::SplineCurve> curves_; ///< per spline
  std::vector<std::unique_ptr<Definition>> definitions_;
  std::vector<Work> work_; ///< last evaluation, sorted by (definition, pair)
  struct Committed {
    double xi_A, xi_B;
    bool active;
  };
  std::map<Key, Committed> committed_;
  int candidates_version_ = 0;
  ContactSummary summary_;
};

} // namespace yarnsim
