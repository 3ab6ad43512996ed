#pragma once
// Results of a run: dir/results.h5 (mesh once, one group per completed step, run metadata and
// end status) and dir/results.xdmf (XDMF 3 over the .h5, opened by ParaView 5.11 with either
// XDMF reader; apply Tube with radius "radius" to draw the yarns, Glyph on "contacts").
//
// results.xdmf holds up to four temporal collections: "yarns" (a Polyline grid per step: the
// 3-node elements as 2-node segments, node and cell attributes, the step's scalars as field
// data), "contacts" (a Polyvertex grid for each step that has contact points), "surfaces" (each
// yarn's true surface, a Quadrilateral grid per step, when the mesh has node sections) and
// "contact_tubes" (the spline contact's tubes, when there are any); yarn_surface.hpp describes the
// last two. ParaView's XDMF reader shows them as blocks of those names; Xdmf3ReaderS merges them
// as pieces of one dataset, Xdmf3ReaderT as unnamed blocks.
//
// Layout of results.h5 (arrays node-major, shape (rows, columns), float64 unless noted):
//   /                       attributes deck_text, deck_path, version, threads (int32), status,
//                           message; status is "running" until close() records the end
//   /mesh/reference_positions (n_nodes, 3)          m
//   /mesh/elements            (n_elements, 3) int32  first, middle, last node (0-based)
//   /mesh/segments            (2 n_elements, 2) int32  element e -> segments 2e (first, middle)
//                                                     and 2e+1 (middle, last)
//   /mesh/node_radius         (n_nodes)             m
//   /mesh/surface_quads       (n_quads, 4) int32    ring point indices (with node sections)
//   /mesh/contact_tube_quads  (n_tube_quads, 4) int32  (with contact tubes)
//   /steps/<000000>           attributes increment (int32), time (s), one double per scalar
//                             (in creation order, tracked)
//     positions, displacement, rotations (n_nodes, 3)            m, m, rad (rotation vector)
//     reaction_force, reaction_moment (n_nodes, 3)              N, N m
//     section_force, section_moment (2 n_elements, 3)           N, N m; row 2e+k is Gauss point
//                                                               k of element e = segment 2e+k
//     contacts/position, contacts/normal (n_contacts, 3)        m, -
//     contacts/gap, contacts/force (n_contacts)                 m, N
//     contacts/vertices (n_contacts) int32                       0 .. n_contacts-1 (for XDMF)
//     contacts/tangential_force (n_contacts, 3), contacts/stick, contacts/slip (n_contacts)
//                                                               N, 1 or 0, m (with friction)
//     contacts/torque (n_contacts)                              N m (with torsional friction)
//     surface/points (12 n_nodes, 3) float32                      m, ring points, node-major
//     contact_tube/points (n_tube_points, 3) float32              m
// Each step is flushed to disk when write_step returns; HDF5 file locking is off so ParaView can
// read while the run writes.

#include "engine/output/hdf5.hpp"
#include "engine/output/yarn_surface.hpp"

#include <Eigen/Core>

#include <array>
#include <chrono>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace yarnsim::output {

/// The undeformed beam mesh, written once.
struct Mesh {
  Eigen::Matrix3Xd reference_positions;     ///< 3 x n_nodes, m
  std::vector<std::array<int, 3>> elements; ///< 3-node beams: first, middle, last (0-based)
  Eigen::VectorXd node_radius;              ///< n_nodes, m (for ParaView's Tube filter)
  /// For the yarn surface (yarn_surface.hpp), both n_nodes long or both empty (no surface): the
  /// section drawn at each node and its reference triad (columns: section axes 1, 2, beam axis).
  std::vector<NodeSection> node_sections;
  std::vector<Eigen::Matrix3d> reference_triads;
  std::vector<ContactTube> contact_tubes; ///< the spline contacts' centre lines (may be empty)
};

/// What produced the results.
struct RunMetadata {
  std::string deck_text; ///< the input deck, verbatim
  std::string deck_path;
  std::string version; ///< yarnsim::kVersion
  int threads = 1;
};

/// Active contact points of a step; all members have n_contacts columns (may be 0).
struct ContactPoints {
  Eigen::Matrix3Xd position; ///< 3 x n_contacts, m
  Eigen::Matrix3Xd normal;   ///< 3 x n_contacts, unit
  Eigen::VectorXd gap;       ///< n_contacts, m (negative: penetration)
  Eigen::VectorXd force;     ///< n_contacts, N (normal force magnitude)
  /// With friction (all n_contacts long, else all empty): the friction force on the point's
  /// first body, N; 1 in stick, 0 in slip; the slip since the point closed, m.
  Eigen::Matrix3Xd tangential_force;
  Eigen::VectorXd stick;
  Eigen::VectorXd slip;
  /// With torsional friction (n_contacts long, else empty): the friction torque about the
  /// normal, N m.
  Eigen::VectorXd torque;
};

/// The state at the end of one completed increment.
struct StepResults {
  int increment = 0;
  double time = 0;                                    ///< s
  Eigen::Matrix3Xd positions;                         ///< 3 x n_nodes, m
  Eigen::Matrix3Xd rotations;                         ///< 3 x n_nodes, total rotation vector, rad
  Eigen::Matrix<double, 6, Eigen::Dynamic> reactions; ///< 6 x n_nodes: N, N m (zero where free)
  /// 6 x (2 n_elements): forces (N) then moments (N m) in the section frame at the two Gauss
  /// points of each element, element-major (column 2e+k is Gauss point k of element e).
  Eigen::Matrix<double, 6, Eigen::Dynamic> section_resultants;
  ContactPoints contacts;
  /// Named scalars of the step, e.g. {"iterations", 4}, {"active_contacts", 12}.
  std::vector<std::pair<std::string, double>> scalars;
};

/// Writes dir/results.h5 and dir/results.xdmf as a run proceeds.
class ResultsFile {
public:
  /// Creates dir (if needed), dir/results.h5 (truncating) with /mesh and the metadata attributes,
  /// and dir/results.xdmf (no steps yet). Throws std::invalid_argument for an inconsistent mesh
  /// (sizes, node indices out of range) and std::runtime_error when a file cannot be written.
  /// xdmf_interval: the shortest time between two rewrites of results.xdmf.
  ResultsFile(const std::filesystem::path& dir, const Mesh& mesh, const RunMetadata& meta,
              std::chrono::milliseconds xdmf_interval = std::chrono::seconds(1));
  /// Goes on with dir/results.h5 of an earlier run of the same model (a restart): keeps its first
  /// keep_steps steps and removes any later ones, writes the metadata attributes anew with status
  /// "running", and rewrites results.xdmf for the kept steps. Throws std::runtime_error when the
  /// file does not open or holds fewer steps, std::invalid_argument when its mesh has other
  /// sizes.
  struct Continue {
    int keep_steps = 0;
  };
  ResultsFile(const std::filesystem::path& dir, const Mesh& mesh, const RunMetadata& meta,
              Continue from, std::chrono::milliseconds xdmf_interval = std::chrono::seconds(1));
  ResultsFile(const ResultsFile&) = delete;
  ResultsFile& operator=(const ResultsFile&) = delete;
  ResultsFile(ResultsFile&&) noexcept = default;
  ResultsFile& operator=(ResultsFile&&) noexcept = default;
  /// Closes the file without recording a status (it stays "running"); never throws.
  ~ResultsFile();

  /// Appends one completed step as /steps/<6-digit index of this step>, flushes the file
  /// (H5Fflush) and rewrites results.xdmf atomically (results.xdmf.tmp, then rename) at most once a
  /// second (always on the first step, at close() and in the destructor). Throws
  /// std::invalid_argument when an array does not match the mesh, std::logic_error after close().
  void write_step(const StepResults& step);

  /// Records why the run ended as root attributes "status" ("completed", "failed: ...",
  /// "interrupted") and "message", flushes and closes the file. Later calls do nothing.
  void close(std::string_view status, std::string_view message);

  int steps_written() const { return steps_written_; }
  const std::filesystem::path& h5_path() const { return h5_path_; }
  const std::filesystem::path& xdmf_path() const { return xdmf_path_; }

private:
  void write_xdmf() const;
  /// Writes /mesh/surface_quads and /mesh/contact_tube_quads where the mesh has them and the file
  /// does not yet, and sets the quad and point counts.
  void write_drawing_mesh(hid_t mesh_group, const Mesh& mesh);
  /// Appends the XDMF grids of step `name` (under /steps) to the two collections.
  void append_xdmf_grids(const std::string& name, double time, int increment,
                         const std::vector<std::pair<std::string, double>>& scalars, int n_contacts,
                         bool friction, bool torque, bool surface, bool tubes);

  std::filesystem::path h5_path_;
  std::filesystem::path xdmf_path_;
  int n_nodes_ = 0;
  int n_elements_ = 0;
  Eigen::Matrix3Xd reference_positions_; ///< for the displacement field
  std::vector<NodeSection> node_sections_;
  std::vector<Eigen::Matrix3d> reference_triads_;
  std::vector<ContactTube> contact_tubes_;
  int n_surface_quads_ = 0;
  int n_tube_points_ = 0;
  int n_tube_quads_ = 0;
  int steps_written_ = 0;
  std::chrono::steady_clock::time_point last_xdmf_{};
  std::chrono::milliseconds xdmf_interval_{1000};
  bool xdmf_stale_ = false; ///< steps written since the XDMF was last rewritten
  /// The <Grid>s of the written steps in the two temporal collections of results.xdmf.
  std::string xdmf_yarns_;
  std::string xdmf_contacts_;
  std::string xdmf_surfaces_;
  std::string xdmf_tubes_;
  h5::Handle file_; ///< declared before steps_group_: destroyed after it
  h5::Handle steps_group_;
};

} // namespace yarnsim::output
