#include "engine/output/results_file.hpp"

#include <chrono>

#include <fmt/format.h>

#include <array>
#include <fstream>
#include <iterator>
#include <numeric>
#include <span>
#include <stdexcept>
#include <system_error>

namespace yarnsim::output {
namespace {

constexpr const char* kH5Name = "results.h5";
constexpr const char* kXdmfName = "results.xdmf";

/// Writes a 3 x n matrix as a dataset of shape (n, 3): Eigen's column-major storage of 3 x n is
/// exactly the row-major (n, 3) array, node by node.
void write_node_vectors(hid_t group, const std::string& name, const Eigen::Matrix3Xd& m) {
  const std::array<hsize_t, 2> dims{static_cast<hsize_t>(m.cols()), 3};
  h5::write_dataset(group, name, std::span<const double>(m.data(), m.size()), dims);
}

void write_vector(hid_t group, const std::string& name, const Eigen::VectorXd& v) {
  const std::array<hsize_t, 1> dims{static_cast<hsize_t>(v.size())};
  h5::write_dataset(group, name, std::span<const double>(v.data(), v.size()), dims);
}

void require_columns(std::string_view what, Eigen::Index found, Eigen::Index expected) {
  if (found != expected)
    throw std::invalid_argument(
        fmt::format("results: {} has {} columns, expected {}", what, found, expected));
}

void require_size(std::string_view what, Eigen::Index found, Eigen::Index expected) {
  if (found != expected)
    throw std::invalid_argument(
        fmt::format("results: {} has {} entries, expected {}", what, found, expected));
}

/// Checks the mesh against its node count; throws std::invalid_argument naming what is wrong.
void check_mesh(const Mesh& mesh, int n_nodes) {
  require_size("mesh node_radius", mesh.node_radius.size(), n_nodes);
  for (std::size_t e = 0; e < mesh.elements.size(); ++e)
    for (int node : mesh.elements[e])
      if (node < 0 || node >= n_nodes)
        throw std::invalid_argument(
            fmt::format("results: mesh element {} refers to node {}, expected 0 <= node < {}", e,
                        node, n_nodes));
  if (!mesh.node_sections.empty() || !mesh.reference_triads.empty()) {
    require_size("mesh node_sections", static_cast<Eigen::Index>(mesh.node_sections.size()),
                 n_nodes);
    require_size("mesh reference_triads", static_cast<Eigen::Index>(mesh.reference_triads.size()),
                 n_nodes);
    for (std::size_t i = 0; i < mesh.node_sections.size(); ++i) {
      const NodeSection& s = mesh.node_sections[i];
      if (!(s.a >= 0 && s.b >= 0 && s.exponent > 0))
        throw std::invalid_argument(fmt::format(
            "results: node {} has section a = {}, b = {}, exponent = {}; expected a, b >= 0 and "
            "exponent > 0",
            i, s.a, s.b, s.exponent));
    }
  }
  for (std::size_t t = 0; t < mesh.contact_tubes.size(); ++t) {
    const ContactTube& tube = mesh.contact_tubes[t];
    if (tube.nodes.size() < 3)
      throw std::invalid_argument(fmt::format(
          "results: contact tube {} has {} nodes, expected at least 3", t, tube.nodes.size()));
    for (int node : tube.nodes)
      if (node < 0 || node >= n_nodes)
        throw std::invalid_argument(
            fmt::format("results: contact tube {} refers to node {}, expected 0 <= node < {}", t,
                        node, n_nodes));
  }
}

void write_quads(hid_t group, const std::string& name,
                 const std::vector<std::array<int, 4>>& quads) {
  h5::write_dataset(group, name, std::span<const int>(quads.data()->data(), 4 * quads.size()),
                    std::array<hsize_t, 2>{quads.size(), 4});
}

void write_points(hid_t group, const std::string& name, const std::vector<float>& xyz) {
  h5::write_dataset(group, name, std::span<const float>(xyz),
                    std::array<hsize_t, 2>{xyz.size() / 3, 3});
}

std::string xml_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
    case '&':
      out += "&amp;";
      break;
    case '<':
      out += "&lt;";
      break;
    case '>':
      out += "&gt;";
      break;
    case '"':
      out += "&quot;";
      break;
    case '\'':
      out += "&apos;";
      break;
    default:
      out += c;
    }
  }
  return out;
}

/// An <Attribute> whose values are an HDF5 dataset in results.h5.
void append_h5_attribute(std::string& xml, std::string_view name, std::string_view type,
                         std::string_view center, std::string_view dimensions,
                         std::string_view h5_path) {
  fmt::format_to(std::back_inserter(xml),
                 "        <Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"{}\">\n"
                 "          <DataItem Dimensions=\"{}\" NumberType=\"Float\" Precision=\"8\" "
                 "Format=\"HDF\">{}:{}</DataItem>\n"
                 "        </Attribute>\n",
                 name, type, center, dimensions, kH5Name, h5_path);
}

/// A Quadrilateral grid of one step: connectivity `quads_path` (shared by all steps), float32
/// points at `points_path`.
void append_quad_grid(std::string& xml, std::string_view name, double time, int n_quads,
                      std::string_view quads_path, int n_points, std::string_view points_path) {
  fmt::format_to(std::back_inserter(xml),
                 "      <Grid Name=\"{0}\" GridType=\"Uniform\">\n"
                 "        <Time Value=\"{1}\"/>\n"
                 "        <Topology TopologyType=\"Quadrilateral\" NumberOfElements=\"{2}\">\n"
                 "          <DataItem Dimensions=\"{2} 4\" NumberType=\"Int\" Precision=\"4\" "
                 "Format=\"HDF\">{3}:{4}</DataItem>\n"
                 "        </Topology>\n"
                 "        <Geometry GeometryType=\"XYZ\">\n"
                 "          <DataItem Dimensions=\"{5} 3\" NumberType=\"Float\" Precision=\"4\" "
                 "Format=\"HDF\">{3}:{6}</DataItem>\n"
                 "        </Geometry>\n"
                 "      </Grid>\n",
                 name, time, n_quads, kH5Name, quads_path, n_points, points_path);
}

/// A grid-centred scalar (ParaView field data), inline in the XML.
void append_grid_scalar(std::string& xml, std::string_view name, double value) {
  fmt::format_to(std::back_inserter(xml),
                 "        <Attribute Name=\"{}\" AttributeType=\"Scalar\" Center=\"Grid\">\n"
                 "          <DataItem Dimensions=\"1\" NumberType=\"Float\" Precision=\"8\" "
                 "Format=\"XML\">{}</DataItem>\n"
                 "        </Attribute>\n",
                 xml_escape(name), value);
}

} // namespace

ResultsFile::ResultsFile(const std::filesystem::path& dir, const Mesh& mesh,
                         const RunMetadata& meta, std::chrono::milliseconds xdmf_interval)
    : h5_path_(dir / kH5Name), xdmf_path_(dir / kXdmfName),
      n_nodes_(static_cast<int>(mesh.reference_positions.cols())),
      n_elements_(static_cast<int>(mesh.elements.size())),
      reference_positions_(mesh.reference_positions), node_sections_(mesh.node_sections),
      reference_triads_(mesh.reference_triads), contact_tubes_(mesh.contact_tubes),
      xdmf_interval_(xdmf_interval) {
  check_mesh(mesh, n_nodes_);

  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec)
    throw std::runtime_error(
        fmt::format("results: cannot create directory {}: {}", dir.string(), ec.message()));

  file_ = h5::create_file(h5_path_);
  const hid_t root = file_.id();
  h5::write_string_attribute(root, "deck_text", meta.deck_text);
  h5::write_string_attribute(root, "deck_path", meta.deck_path);
  h5::write_string_attribute(root, "version", meta.version);
  h5::write_int_attribute(root, "threads", meta.threads);
  h5::write_string_attribute(root, "status", "running");
  h5::write_string_attribute(root, "message", "");

  h5::Handle group = h5::create_group(root, "mesh");
  write_node_vectors(group.id(), "reference_positions", mesh.reference_positions);
  write_vector(group.id(), "node_radius", mesh.node_radius);
  std::vector<int> elements;
  std::vector<int> segments;
  elements.reserve(3 * mesh.elements.size());
  segments.reserve(4 * mesh.elements.size());
  for (const auto& [first, middle, last] : mesh.elements) {
    elements.insert(elements.end(), {first, middle, last});
    segments.insert(segments.end(), {first, middle, middle, last});
  }
  const auto n_elements = static_cast<hsize_t>(n_elements_);
  h5::write_dataset(group.id(), "elements", std::span<const int>(elements),
                    std::array<hsize_t, 2>{n_elements, 3});
  h5::write_dataset(group.id(), "segments", std::span<const int>(segments),
                    std::array<hsize_t, 2>{2 * n_elements, 2});
  write_drawing_mesh(group.id(), mesh);
  group.close();

  steps_group_ = h5::create_group(root, "steps");
  h5::flush(root);
  write_xdmf();
}

ResultsFile::ResultsFile(const std::filesystem::path& dir, const Mesh& mesh,
                         const RunMetadata& meta, Continue from,
                         std::chrono::milliseconds xdmf_interval)
    : h5_path_(dir / kH5Name), xdmf_path_(dir / kXdmfName),
      n_nodes_(static_cast<int>(mesh.reference_positions.cols())),
      n_elements_(static_cast<int>(mesh.elements.size())),
      reference_positions_(mesh.reference_positions), node_sections_(mesh.node_sections),
      reference_triads_(mesh.reference_triads), contact_tubes_(mesh.contact_tubes),
      xdmf_interval_(xdmf_interval) {
  check_mesh(mesh, n_nodes_);
  if (!std::filesystem::exists(h5_path_))
    throw std::runtime_error(
        fmt::format("results: cannot continue {}: the file is missing", h5_path_.string()));
  file_ = h5::open_file_read_write(h5_path_);
  const hid_t root = file_.id();
  {
    h5::Handle group = h5::open_group(root, "mesh");
    std::vector<hsize_t> nodes, elements;
    h5::read_doubles(group.id(), "reference_positions", &nodes);
    h5::read_ints(group.id(), "elements", &elements);
    if (nodes.size() != 2 || nodes[0] != hsize_t(n_nodes_) || elements.size() != 2 ||
        elements[0] != hsize_t(n_elements_))
      throw std::invalid_argument(fmt::format(
          "results: cannot continue {}: its mesh has {} nodes and {} elements, the model {} and {}",
          h5_path_.string(), nodes.empty() ? 0 : nodes[0], elements.empty() ? 0 : elements[0],
          n_nodes_, n_elements_));
    // A file written before the drawing meshes existed gets them now; its earlier steps keep
    // drawing the centre lines only.
    write_drawing_mesh(group.id(), mesh);
  }
  h5::write_string_attribute(root, "deck_text", meta.deck_text);
  h5::write_string_attribute(root, "deck_path", meta.deck_path);
  h5::write_string_attribute(root, "version", meta.version);
  h5::write_int_attribute(root, "threads", meta.threads);
  h5::write_string_attribute(root, "status", "running");
  h5::write_string_attribute(root, "message", "");

  steps_group_ = h5::open_group(root, "steps");
  const std::vector<std::string> names = h5::link_names(steps_group_.id());
  if (static_cast<int>(names.size()) < from.keep_steps)
    throw std::runtime_error(
        fmt::format("results: cannot continue {}: it holds {} steps, the checkpoint {}",
                    h5_path_.string(), names.size(), from.keep_steps));
  // Steps written after the checkpoint (a run killed between the two) go.
  for (std::size_t k = from.keep_steps; k < names.size(); ++k)
    h5::remove(steps_group_.id(), names[k]);
  for (int k = 0; k < from.keep_steps; ++k) {
    const std::string name = fmt::format("{:06d}", k);
    if (names[k] != name)
      throw std::runtime_error(fmt::format("results: cannot continue {}: step {} is called '{}'",
                                           h5_path_.string(), k, names[k]));
    h5::Handle group = h5::open_group(steps_group_.id(), name);
    std::vector<std::pair<std::string, double>> scalars;
    for (const std::string& attribute : h5::attribute_names(group.id()))
      if (attribute != "increment" && attribute != "time")
        scalars.emplace_back(attribute, h5::read_double_attribute(group.id(), attribute));
    std::vector<hsize_t> dims;
    h5::read_doubles(group.id(), "contacts/gap", &dims);
    append_xdmf_grids(name, h5::read_double_attribute(group.id(), "time"),
                      h5::read_int_attribute(group.id(), "increment"), scalars,
                      dims.empty() ? 0 : static_cast<int>(dims[0]),
                      h5::exists(group.id(), "contacts/tangential_force"),
                      h5::exists(group.id(), "contacts/torque"), h5::exists(group.id(), "surface"),
                      h5::exists(group.id(), "contact_tube"));
  }
  steps_written_ = from.keep_steps;
  h5::flush(root);
  write_xdmf();
  last_xdmf_ = std::chrono::steady_clock::now();
}

ResultsFile::~ResultsFile() {
  if (xdmf_stale_) {
    try {
      write_xdmf();
    } catch (...) { // a destructor never throws; the .h5 holds every step anyway
    }
  }
}

void ResultsFile::write_step(const StepResults& step) {
  if (!file_.valid())
    throw std::logic_error(
        fmt::format("results: write_step after close() of {}", h5_path_.string()));
  require_columns("step positions", step.positions.cols(), n_nodes_);
  require_columns("step rotations", step.rotations.cols(), n_nodes_);
  require_columns("step reactions", step.reactions.cols(), n_nodes_);
  require_columns("step section_resultants", step.section_resultants.cols(), 2 * n_elements_);
  const ContactPoints& contacts = step.contacts;
  const auto n_contacts = static_cast<int>(contacts.position.cols());
  require_columns("contact normal", contacts.normal.cols(), n_contacts);
  require_size("contact gap", contacts.gap.size(), n_contacts);
  require_size("contact force", contacts.force.size(), n_contacts);
  const bool friction =
      contacts.tangential_force.cols() > 0 || contacts.stick.size() > 0 || contacts.slip.size() > 0;
  if (friction) {
    require_columns("contact tangential_force", contacts.tangential_force.cols(), n_contacts);
    require_size("contact stick", contacts.stick.size(), n_contacts);
    require_size("contact slip", contacts.slip.size(), n_contacts);
  }
  const bool torque = contacts.torque.size() > 0;
  if (torque)
    require_size("contact torque", contacts.torque.size(), n_contacts);
  for (std::size_t i = 0; i < step.scalars.size(); ++i) {
    const std::string& scalar = step.scalars[i].first;
    if (scalar.empty() || scalar == "increment" || scalar == "time")
      throw std::invalid_argument(
          fmt::format("results: step scalar {} is named '{}'; expected a non-empty name other than "
                      "'increment' and 'time'",
                      i, scalar));
    for (std::size_t j = 0; j < i; ++j)
      if (step.scalars[j].first == scalar)
        throw std::invalid_argument(fmt::format(
            "results: step scalar '{}' appears twice (entries {} and {})", scalar, j, i));
  }

  const std::string name = fmt::format("{:06d}", steps_written_);
  // Attribute order tracked: a restart lists the scalars in results.xdmf in the same order.
  h5::Handle group = h5::create_group(steps_group_.id(), name, true);
  const hid_t g = group.id();
  h5::write_int_attribute(g, "increment", step.increment);
  h5::write_double_attribute(g, "time", step.time);
  for (const auto& [scalar, value] : step.scalars)
    h5::write_double_attribute(g, scalar, value);

  write_node_vectors(g, "positions", step.positions);
  write_node_vectors(g, "displacement", step.positions - reference_positions_);
  write_node_vectors(g, "rotations", step.rotations);
  write_node_vectors(g, "reaction_force", step.reactions.topRows<3>());
  write_node_vectors(g, "reaction_moment", step.reactions.bottomRows<3>());
  write_node_vectors(g, "section_force", step.section_resultants.topRows<3>());
  write_node_vectors(g, "section_moment", step.section_resultants.bottomRows<3>());

  h5::Handle contact_group = h5::create_group(g, "contacts");
  write_node_vectors(contact_group.id(), "position", contacts.position);
  write_node_vectors(contact_group.id(), "normal", contacts.normal);
  write_vector(contact_group.id(), "gap", contacts.gap);
  write_vector(contact_group.id(), "force", contacts.force);
  if (friction) {
    write_node_vectors(contact_group.id(), "tangential_force", contacts.tangential_force);
    write_vector(contact_group.id(), "stick", contacts.stick);
    write_vector(contact_group.id(), "slip", contacts.slip);
  }
  if (torque)
    write_vector(contact_group.id(), "torque", contacts.torque);
  std::vector<int> vertices(static_cast<std::size_t>(n_contacts));
  std::iota(vertices.begin(), vertices.end(), 0);
  h5::write_dataset(contact_group.id(), "vertices", std::span<const int>(vertices),
                    std::array<hsize_t, 1>{static_cast<hsize_t>(n_contacts)});
  contact_group.close();
  const bool surface = !node_sections_.empty();
  if (surface) {
    h5::Handle surface_group = h5::create_group(g, "surface");
    write_points(surface_group.id(), "points",
                 surface_points(step.positions, step.rotations, reference_triads_, node_sections_));
  }
  const bool tubes = !contact_tubes_.empty();
  if (tubes) {
    h5::Handle tube_group = h5::create_group(g, "contact_tube");
    write_points(tube_group.id(), "points", tube_points(step.positions, contact_tubes_));
  }
  group.close();
  h5::flush(file_.id());

  append_xdmf_grids(name, step.time, step.increment, step.scalars, n_contacts, friction, torque,
                    surface, tubes);
  ++steps_written_;
  // The XDMF is rewritten whole, so rewriting it at every step of a long run would cost the
  // square of the step count: at most once a second, and always at the end. The .h5 holds
  // every step as soon as this returns.
  const auto now = std::chrono::steady_clock::now();
  if (steps_written_ == 1 || now - last_xdmf_ >= xdmf_interval_) {
    write_xdmf();
    last_xdmf_ = now;
    xdmf_stale_ = false;
  } else {
    xdmf_stale_ = true;
  }
}

void ResultsFile::append_xdmf_grids(const std::string& name, double time, int increment,
                                    const std::vector<std::pair<std::string, double>>& scalars,
                                    int n_contacts, bool friction, bool torque, bool surface,
                                    bool tubes) {
  // This step's grids in results.xdmf. Connectivity and radius are the mesh's, shared by all
  // steps. A step without contacts has no "contacts" grid: the readers then show no contact
  // block at that time (an empty HDF5 DataItem makes the XDMF 2 reader report an error).
  const std::string step_path = "/steps/" + name;
  const std::string nodes3 = fmt::format("{} 3", n_nodes_);
  const std::string cells3 = fmt::format("{} 3", 2 * n_elements_);
  std::string& yarns = xdmf_yarns_;
  fmt::format_to(std::back_inserter(yarns),
                 "      <Grid Name=\"yarns\" GridType=\"Uniform\">\n"
                 "        <Time Value=\"{0}\"/>\n"
                 "        <Topology TopologyType=\"Polyline\" NodesPerElement=\"2\" "
                 "NumberOfElements=\"{1}\">\n"
                 "          <DataItem Dimensions=\"{1} 2\" NumberType=\"Int\" Precision=\"4\" "
                 "Format=\"HDF\">{2}:/mesh/segments</DataItem>\n"
                 "        </Topology>\n"
                 "        <Geometry GeometryType=\"XYZ\">\n"
                 "          <DataItem Dimensions=\"{3} 3\" NumberType=\"Float\" Precision=\"8\" "
                 "Format=\"HDF\">{2}:{4}/positions</DataItem>\n"
                 "        </Geometry>\n",
                 time, 2 * n_elements_, kH5Name, n_nodes_, step_path);
  append_h5_attribute(yarns, "displacement", "Vector", "Node", nodes3, step_path + "/displacement");
  append_h5_attribute(yarns, "rotation", "Vector", "Node", nodes3, step_path + "/rotations");
  append_h5_attribute(yarns, "reaction_force", "Vector", "Node", nodes3,
                      step_path + "/reaction_force");
  append_h5_attribute(yarns, "reaction_moment", "Vector", "Node", nodes3,
                      step_path + "/reaction_moment");
  append_h5_attribute(yarns, "radius", "Scalar", "Node", std::to_string(n_nodes_),
                      "/mesh/node_radius");
  append_h5_attribute(yarns, "section_force", "Vector", "Cell", cells3,
                      step_path + "/section_force");
  append_h5_attribute(yarns, "section_moment", "Vector", "Cell", cells3,
                      step_path + "/section_moment");
  append_grid_scalar(yarns, "increment", increment);
  for (const auto& [scalar, value] : scalars)
    append_grid_scalar(yarns, scalar, value);
  yarns += "      </Grid>\n";

  if (n_contacts > 0) {
    // One vertex cell per point, so that ParaView also draws them without a Glyph.
    const std::string contacts3 = fmt::format("{} 3", n_contacts);
    const std::string path = step_path + "/contacts";
    fmt::format_to(std::back_inserter(xdmf_contacts_),
                   "      <Grid Name=\"contacts\" GridType=\"Uniform\">\n"
                   "        <Time Value=\"{0}\"/>\n"
                   "        <Topology TopologyType=\"Polyvertex\" NodesPerElement=\"1\" "
                   "NumberOfElements=\"{1}\">\n"
                   "          <DataItem Dimensions=\"{1}\" NumberType=\"Int\" Precision=\"4\" "
                   "Format=\"HDF\">{2}:{3}/vertices</DataItem>\n"
                   "        </Topology>\n"
                   "        <Geometry GeometryType=\"XYZ\">\n"
                   "          <DataItem Dimensions=\"{1} 3\" NumberType=\"Float\" "
                   "Precision=\"8\" Format=\"HDF\">{2}:{3}/position</DataItem>\n"
                   "        </Geometry>\n",
                   time, n_contacts, kH5Name, path);
    append_h5_attribute(xdmf_contacts_, "normal", "Vector", "Node", contacts3, path + "/normal");
    append_h5_attribute(xdmf_contacts_, "gap", "Scalar", "Node", std::to_string(n_contacts),
                        path + "/gap");
    append_h5_attribute(xdmf_contacts_, "force", "Scalar", "Node", std::to_string(n_contacts),
                        path + "/force");
    if (friction) {
      append_h5_attribute(xdmf_contacts_, "tangential_force", "Vector", "Node", contacts3,
                          path + "/tangential_force");
      append_h5_attribute(xdmf_contacts_, "stick", "Scalar", "Node", std::to_string(n_contacts),
                          path + "/stick");
      append_h5_attribute(xdmf_contacts_, "slip", "Scalar", "Node", std::to_string(n_contacts),
                          path + "/slip");
    }
    if (torque)
      append_h5_attribute(xdmf_contacts_, "torque", "Scalar", "Node", std::to_string(n_contacts),
                          path + "/torque");
    xdmf_contacts_ += "      </Grid>\n";
  }
  if (surface)
    append_quad_grid(xdmf_surfaces_, "surfaces", time, n_surface_quads_, "/mesh/surface_quads",
                     kRingPoints * n_nodes_, step_path + "/surface/points");
  if (tubes)
    append_quad_grid(xdmf_tubes_, "contact_tubes", time, n_tube_quads_, "/mesh/contact_tube_quads",
                     n_tube_points_, step_path + "/contact_tube/points");
}

void ResultsFile::write_drawing_mesh(hid_t mesh_group, const Mesh& mesh) {
  if (!mesh.node_sections.empty()) {
    const std::vector<std::array<int, 4>> quads = surface_quads(mesh.elements);
    n_surface_quads_ = static_cast<int>(quads.size());
    if (!h5::exists(mesh_group, "surface_quads"))
      write_quads(mesh_group, "surface_quads", quads);
  }
  if (!mesh.contact_tubes.empty()) {
    const std::vector<std::array<int, 4>> quads = tube_quads(mesh.contact_tubes);
    n_tube_quads_ = static_cast<int>(quads.size());
    n_tube_points_ = 0;
    for (const ContactTube& tube : mesh.contact_tubes)
      n_tube_points_ += tube_point_count(tube);
    if (!h5::exists(mesh_group, "contact_tube_quads"))
      write_quads(mesh_group, "contact_tube_quads", quads);
  }
}

void ResultsFile::close(std::string_view status, std::string_view message) {
  if (!file_.valid())
    return;
  if (xdmf_stale_) {
    write_xdmf();
    xdmf_stale_ = false;
  }
  h5::write_string_attribute(file_.id(), "status", status);
  h5::write_string_attribute(file_.id(), "message", message);
  h5::flush(file_.id());
  steps_group_.close();
  file_.close();
}

void ResultsFile::write_xdmf() const {
  // Written whole to a temporary and renamed over the old file, so a reader never sees a
  // half-written XDMF.
  std::filesystem::path tmp = xdmf_path_;
  tmp += ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << "<?xml version=\"1.0\" ?>\n"
           "<Xdmf Version=\"3.0\">\n"
           "  <Domain>\n"
           "    <Grid Name=\"yarns\" GridType=\"Collection\" CollectionType=\"Temporal\">\n"
        << xdmf_yarns_
        << "    </Grid>\n"
           "    <Grid Name=\"contacts\" GridType=\"Collection\" CollectionType=\"Temporal\">\n"
        << xdmf_contacts_ << "    </Grid>\n";
    if (!node_sections_.empty())
      out << "    <Grid Name=\"surfaces\" GridType=\"Collection\" CollectionType=\"Temporal\">\n"
          << xdmf_surfaces_ << "    </Grid>\n";
    if (!contact_tubes_.empty())
      out << "    <Grid Name=\"contact_tubes\" GridType=\"Collection\" "
             "CollectionType=\"Temporal\">\n"
          << xdmf_tubes_ << "    </Grid>\n";
    out << ""
           "  </Domain>\n"
           "</Xdmf>\n";
    out.close();
    if (!out)
      throw std::runtime_error(fmt::format("results: cannot write {}", tmp.string()));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, xdmf_path_, ec);
  if (ec)
    throw std::runtime_error(fmt::format("results: cannot rename {} to {}: {}", tmp.string(),
                                         xdmf_path_.string(), ec.message()));
}

} // namespace yarnsim::output
