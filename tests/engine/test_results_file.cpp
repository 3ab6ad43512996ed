// Results output: results.h5 read back with the plain HDF5 C API, results.xdmf checked as XML,
// the "flushed as steps complete" guarantee, and CSV histories.

#include "engine/output/csv_writer.hpp"
#include "engine/output/results_file.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;
using yarnsim::output::ContactPoints;
using yarnsim::output::CsvWriter;
using yarnsim::output::Mesh;
using yarnsim::output::ResultsFile;
using yarnsim::output::RunMetadata;
using yarnsim::output::StepResults;

/// A fresh directory per test, removed afterwards.
class ResultsOutput : public ::testing::Test {
protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = fs::temp_directory_path() / (std::string("yarnsim_") + info->test_suite_name() + "_" +
                                       info->name() + "_" + std::to_string(::getpid()));
    fs::remove_all(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  fs::path dir;
};

// ---- reading back with the HDF5 C API only (not the writer's wrapper) ----

struct Array {
  std::vector<hsize_t> dims;
  std::vector<double> values;
};

Array read_array(hid_t file, const std::string& path) {
  Array a;
  const hid_t dataset = H5Dopen2(file, path.c_str(), H5P_DEFAULT);
  EXPECT_GE(dataset, 0) << path;
  if (dataset < 0)
    return a;
  const hid_t space = H5Dget_space(dataset);
  const int rank = H5Sget_simple_extent_ndims(space);
  a.dims.resize(rank);
  H5Sget_simple_extent_dims(space, a.dims.data(), nullptr);
  hsize_t n = 1;
  for (hsize_t d : a.dims)
    n *= d;
  a.values.resize(n);
  if (n > 0) {
    EXPECT_GE(H5Dread(dataset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.values.data()),
              0);
  }
  H5Sclose(space);
  H5Dclose(dataset);
  return a;
}

std::string read_string_attribute(hid_t object, const std::string& name) {
  const hid_t attribute = H5Aopen(object, name.c_str(), H5P_DEFAULT);
  EXPECT_GE(attribute, 0) << name;
  if (attribute < 0)
    return {};
  const hid_t type = H5Aget_type(attribute);
  EXPECT_EQ(H5Tget_class(type), H5T_STRING);
  EXPECT_GT(H5Tis_variable_str(type), 0);
  char* text = nullptr;
  EXPECT_GE(H5Aread(attribute, type, &text), 0);
  std::string result = text ? text : "";
  H5free_memory(text);
  H5Tclose(type);
  H5Aclose(attribute);
  return result;
}

double read_number_attribute(hid_t object, const std::string& name) {
  const hid_t attribute = H5Aopen(object, name.c_str(), H5P_DEFAULT);
  EXPECT_GE(attribute, 0) << name;
  double value = -1;
  if (attribute >= 0) {
    EXPECT_GE(H5Aread(attribute, H5T_NATIVE_DOUBLE, &value), 0);
    H5Aclose(attribute);
  }
  return value;
}

hid_t open_read_only(const fs::path& file) {
  const hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_file_locking(fapl, false, true);
  const hid_t id = H5Fopen(file.c_str(), H5F_ACC_RDONLY, fapl);
  H5Pclose(fapl);
  return id;
}

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1))
    ++n;
  return n;
}

/// Light well-formedness check: every element closes in order. Returns "" or what is wrong.
std::string xml_nesting_error(const std::string& xml) {
  std::vector<std::string> open;
  for (auto lt = xml.find('<'); lt != std::string::npos; lt = xml.find('<', lt + 1)) {
    const auto gt = xml.find('>', lt);
    if (gt == std::string::npos)
      return "unterminated tag";
    const std::string tag = xml.substr(lt + 1, gt - lt - 1);
    if (tag.starts_with("?") || tag.starts_with("!"))
      continue;
    if (tag.starts_with("/")) {
      if (open.empty() || open.back() != tag.substr(1))
        return "unexpected </" + tag.substr(1) + ">";
      open.pop_back();
    } else if (!tag.ends_with("/")) {
      open.push_back(tag.substr(0, tag.find_first_of(" \n")));
    }
  }
  return open.empty() ? "" : "unclosed <" + open.back() + ">";
}

// ---- a small model: 5 nodes, two 3-node elements ----

constexpr int kNodes = 5;
constexpr int kElements = 2;

Mesh test_mesh() {
  Mesh mesh;
  mesh.reference_positions.resize(3, kNodes);
  for (int i = 0; i < kNodes; ++i)
    mesh.reference_positions.col(i) << 0.001 * i, 0.0, 0.0002 * i;
  mesh.elements = {{0, 1, 2}, {2, 3, 4}};
  mesh.node_radius = Eigen::VectorXd::LinSpaced(kNodes, 1e-4, 2e-4);
  return mesh;
}

/// test_mesh with what the drawing meshes need: an elliptical section at every node (node 4's
/// super-elliptical), turned reference triads, and one contact tube over all five nodes.
Mesh drawn_mesh() {
  Mesh mesh = test_mesh();
  for (int i = 0; i < kNodes; ++i) {
    mesh.node_sections.push_back({2e-4, 1e-4, i == 4 ? 4.0 : 2.0});
    mesh.reference_triads.push_back(
        Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix());
  }
  mesh.contact_tubes.push_back({{0, 1, 2, 3, 4}, 1.5e-4});
  return mesh;
}

RunMetadata test_metadata() {
  return {"[model]\ntitle = \"plain weave\"\n", "decks/plain.toml", "0.1.0-test", 4};
}

/// Step k: every value is distinct, so a transposed or misplaced array shows up.
StepResults test_step(int k) {
  const Mesh mesh = test_mesh();
  StepResults s;
  s.increment = 10 * (k + 1);
  s.time = 0.25 * (k + 1);
  s.positions = mesh.reference_positions;
  s.positions.row(2).array() += 1e-5 * (k + 1);
  s.rotations.resize(3, kNodes);
  s.reactions.resize(6, kNodes);
  for (int i = 0; i < kNodes; ++i)
    for (int r = 0; r < 6; ++r) {
      if (r < 3)
        s.rotations(r, i) = 0.01 * (k + 1) + 0.001 * i + 0.0001 * r;
      s.reactions(r, i) = 1000.0 * k + 10.0 * i + r;
    }
  s.section_resultants.resize(6, 2 * kElements);
  for (int c = 0; c < 2 * kElements; ++c)
    for (int r = 0; r < 6; ++r)
      s.section_resultants(r, c) = -1000.0 * k - 10.0 * c - r;
  const int n_contacts = k; // none in the first step
  s.contacts.position = Eigen::Matrix3Xd::Constant(3, n_contacts, 0.5e-3);
  s.contacts.normal = Eigen::Matrix3Xd::Zero(3, n_contacts);
  s.contacts.normal.row(2).setOnes();
  s.contacts.gap = Eigen::VectorXd::Constant(n_contacts, -1e-6 * (k + 1));
  s.contacts.force = Eigen::VectorXd::LinSpaced(n_contacts, 0.5, 0.5 * n_contacts);
  s.scalars = {{"iterations", 3.0 + k}, {"active_contacts", n_contacts}};
  return s;
}

/// Expects a dataset of shape (rows, cols) holding the node-major transpose of m.
template <class Matrix>
void expect_node_major(hid_t file, const std::string& path, const Matrix& m) {
  SCOPED_TRACE(path);
  const Array a = read_array(file, path);
  ASSERT_EQ(a.dims, (std::vector<hsize_t>{hsize_t(m.cols()), hsize_t(m.rows())}));
  for (Eigen::Index i = 0; i < m.cols(); ++i)
    for (Eigen::Index r = 0; r < m.rows(); ++r)
      ASSERT_EQ(a.values[i * m.rows() + r], m(r, i)) << "row " << i << ", column " << r;
}

TEST_F(ResultsOutput, MeshAndMetadataAreWrittenOnConstruction) {
  const Mesh mesh = test_mesh();
  const RunMetadata meta = test_metadata();
  ResultsFile results(dir, mesh, meta, std::chrono::milliseconds(0));
  EXPECT_EQ(results.steps_written(), 0);
  EXPECT_TRUE(fs::exists(dir / "results.xdmf"));

  const hid_t file = open_read_only(dir / "results.h5");
  ASSERT_GE(file, 0);
  EXPECT_EQ(read_string_attribute(file, "deck_text"), meta.deck_text);
  EXPECT_EQ(read_string_attribute(file, "deck_path"), meta.deck_path);
  EXPECT_EQ(read_string_attribute(file, "version"), meta.version);
  EXPECT_EQ(read_number_attribute(file, "threads"), 4);
  EXPECT_EQ(read_string_attribute(file, "status"), "running");

  expect_node_major(file, "/mesh/reference_positions", mesh.reference_positions);
  const Array radius = read_array(file, "/mesh/node_radius");
  EXPECT_EQ(radius.dims, std::vector<hsize_t>{kNodes});
  EXPECT_EQ(Eigen::Map<const Eigen::VectorXd>(radius.values.data(), kNodes), mesh.node_radius);
  const Array elements = read_array(file, "/mesh/elements");
  EXPECT_EQ(elements.dims, (std::vector<hsize_t>{kElements, 3}));
  EXPECT_EQ(elements.values, (std::vector<double>{0, 1, 2, 2, 3, 4}));
  const Array segments = read_array(file, "/mesh/segments");
  EXPECT_EQ(segments.dims, (std::vector<hsize_t>{2 * kElements, 2}));
  EXPECT_EQ(segments.values, (std::vector<double>{0, 1, 1, 2, 2, 3, 3, 4}));
  H5Fclose(file);
}

TEST_F(ResultsOutput, EveryStepIsWrittenNodeMajorWithDisplacementAndSectionResultants) {
  const Mesh mesh = test_mesh();
  {
    ResultsFile results(dir, mesh, test_metadata(), std::chrono::milliseconds(0));
    for (int k = 0; k < 3; ++k)
      results.write_step(test_step(k));
    EXPECT_EQ(results.steps_written(), 3);
    results.close("completed", "");
  }
  const hid_t file = open_read_only(dir / "results.h5");
  ASSERT_GE(file, 0);
  for (int k = 0; k < 3; ++k) {
    const StepResults s = test_step(k);
    const std::string step = "/steps/00000" + std::to_string(k);
    SCOPED_TRACE(step);
    const hid_t group = H5Gopen2(file, step.c_str(), H5P_DEFAULT);
    ASSERT_GE(group, 0);
    EXPECT_EQ(read_number_attribute(group, "increment"), s.increment);
    EXPECT_EQ(read_number_attribute(group, "time"), s.time);
    EXPECT_EQ(read_number_attribute(group, "iterations"), 3.0 + k);
    EXPECT_EQ(read_number_attribute(group, "active_contacts"), k);
    H5Gclose(group);

    expect_node_major(file, step + "/positions", s.positions);
    const Eigen::Matrix3Xd displacement = s.positions - mesh.reference_positions;
    expect_node_major(file, step + "/displacement", displacement);
    expect_node_major(file, step + "/rotations", s.rotations);
    expect_node_major(file, step + "/reaction_force", s.reactions.topRows<3>());
    expect_node_major(file, step + "/reaction_moment", s.reactions.bottomRows<3>());
    // Row 2e+k: Gauss point k of element e, the cell of segment 2e+k.
    expect_node_major(file, step + "/section_force", s.section_resultants.topRows<3>());
    expect_node_major(file, step + "/section_moment", s.section_resultants.bottomRows<3>());

    expect_node_major(file, step + "/contacts/position", s.contacts.position);
    expect_node_major(file, step + "/contacts/normal", s.contacts.normal);
    const Array vertices = read_array(file, step + "/contacts/vertices");
    EXPECT_EQ(vertices.dims, std::vector<hsize_t>{hsize_t(k)});
    for (int i = 0; i < k; ++i)
      EXPECT_EQ(vertices.values[i], i);
    const Array gap = read_array(file, step + "/contacts/gap");
    EXPECT_EQ(gap.dims, std::vector<hsize_t>{hsize_t(k)});
    EXPECT_EQ(std::vector<double>(s.contacts.gap.begin(), s.contacts.gap.end()), gap.values);
    const Array force = read_array(file, step + "/contacts/force");
    EXPECT_EQ(std::vector<double>(s.contacts.force.begin(), s.contacts.force.end()), force.values);
  }
  H5Fclose(file);
}

TEST_F(ResultsOutput, XdmfListsEveryStepOverTheSharedSegments) {
  ResultsFile results(dir, test_mesh(), test_metadata(), std::chrono::milliseconds(0));
  for (int k = 0; k < 3; ++k)
    results.write_step(test_step(k));

  const std::string xml = read_text(dir / "results.xdmf");
  EXPECT_EQ(xml_nesting_error(xml), "");
  EXPECT_FALSE(fs::exists(dir / "results.xdmf.tmp"));
  // Two temporal collections: "yarns" (every step), then "contacts" (steps with contacts).
  EXPECT_EQ(count(xml, "CollectionType=\"Temporal\""), 2u);
  const auto contacts_at = xml.find("<Grid Name=\"contacts\" GridType=\"Collection\"");
  ASSERT_NE(contacts_at, std::string::npos);
  const std::string yarns = xml.substr(0, contacts_at);
  const std::string contacts = xml.substr(contacts_at);
  EXPECT_EQ(count(yarns, "<Time "), 3u);
  EXPECT_EQ(count(yarns, "<Grid Name=\"yarns\" GridType=\"Uniform\""), 3u);
  EXPECT_NE(yarns.find("<Time Value=\"0.25\"/>"), std::string::npos);
  EXPECT_NE(yarns.find("<Time Value=\"0.75\"/>"), std::string::npos);
  EXPECT_EQ(count(xml, "TopologyType=\"Polyline\" NodesPerElement=\"2\" NumberOfElements=\"4\""),
            3u);
  EXPECT_EQ(count(xml, "results.h5:/mesh/segments"), 3u);
  EXPECT_NE(xml.find("Dimensions=\"5 3\" NumberType=\"Float\" Precision=\"8\" "
                     "Format=\"HDF\">results.h5:/steps/000002/positions"),
            std::string::npos);
  for (const char* name : {"displacement", "rotation", "reaction_force", "reaction_moment",
                           "radius", "section_force", "section_moment"})
    EXPECT_EQ(count(xml, std::string("Attribute Name=\"") + name + "\""), 3u) << name;
  EXPECT_EQ(count(xml, "Center=\"Cell\""), 6u);
  // Contacts only at the steps that have some (steps 1 and 2, times 0.5 and 0.75).
  EXPECT_EQ(count(contacts, "<Grid Name=\"contacts\" GridType=\"Uniform\""), 2u);
  EXPECT_EQ(count(contacts, "<Time "), 2u);
  EXPECT_EQ(contacts.find("<Time Value=\"0.25\"/>"), std::string::npos);
  EXPECT_EQ(xml.find("/steps/000000/contacts"), std::string::npos);
  EXPECT_NE(
      contacts.find("TopologyType=\"Polyvertex\" NodesPerElement=\"1\" NumberOfElements=\"2\""),
      std::string::npos);
  for (const char* name : {"vertices", "position", "normal", "gap", "force"})
    EXPECT_NE(contacts.find(std::string("results.h5:/steps/000002/contacts/") + name),
              std::string::npos)
        << name;
}

TEST_F(ResultsOutput, CloseRecordsStatusAndMessage) {
  {
    ResultsFile results(dir, test_mesh(), test_metadata(), std::chrono::milliseconds(0));
    results.write_step(test_step(0));
    results.close("failed: Newton did not converge", "increment 10, residual 3.2e-2 > 1e-4");
    EXPECT_THROW(results.write_step(test_step(1)), std::logic_error);
    results.close("completed", ""); // no effect after the first close
  }
  const hid_t file = open_read_only(dir / "results.h5");
  ASSERT_GE(file, 0);
  EXPECT_EQ(read_string_attribute(file, "status"), "failed: Newton did not converge");
  EXPECT_EQ(read_string_attribute(file, "message"), "increment 10, residual 3.2e-2 > 1e-4");
  H5Fclose(file);
}

TEST_F(ResultsOutput, StepsAreOnDiskWhileTheWriterIsStillOpen) {
  ResultsFile results(dir, test_mesh(), test_metadata(), std::chrono::milliseconds(0));
  results.write_step(test_step(0));
  results.write_step(test_step(1));

  // What another process would see now: a byte copy of the file as it is on disk.
  const fs::path copy = dir / "copy.h5";
  fs::copy_file(dir / "results.h5", copy);
  for (const fs::path& path : {copy, dir / "results.h5"}) {
    SCOPED_TRACE(path);
    const hid_t file = open_read_only(path);
    ASSERT_GE(file, 0);
    EXPECT_EQ(read_string_attribute(file, "status"), "running");
    expect_node_major(file, "/steps/000000/positions", test_step(0).positions);
    expect_node_major(file, "/steps/000001/section_moment",
                      test_step(1).section_resultants.bottomRows<3>());
    EXPECT_EQ(H5Lexists(file, "/steps/000002", H5P_DEFAULT), 0);
    H5Fclose(file);
  }
  EXPECT_EQ(count(read_text(dir / "results.xdmf"), "<Grid Name=\"yarns\" GridType=\"Uniform\""),
            2u);
}

TEST_F(ResultsOutput, LongDeckTextIsKeptWhole) {
  RunMetadata meta = test_metadata();
  meta.deck_text = std::string(200000, 'x') + "\nend";
  { ResultsFile results(dir, test_mesh(), meta, std::chrono::milliseconds(0)); }
  const hid_t file = open_read_only(dir / "results.h5");
  ASSERT_GE(file, 0);
  EXPECT_EQ(read_string_attribute(file, "deck_text"), meta.deck_text);
  H5Fclose(file);
}

TEST_F(ResultsOutput, ArraysThatDoNotMatchTheMeshAreRejected) {
  Mesh bad = test_mesh();
  bad.elements.push_back({4, 5, 6});
  EXPECT_THROW(ResultsFile(dir, bad, test_metadata()), std::invalid_argument);

  ResultsFile results(dir, test_mesh(), test_metadata(), std::chrono::milliseconds(0));
  StepResults s = test_step(1);
  s.section_resultants.resize(6, kElements);
  EXPECT_THROW(results.write_step(s), std::invalid_argument);
  s = test_step(2);
  s.contacts.gap.resize(1);
  EXPECT_THROW(results.write_step(s), std::invalid_argument);
  s = test_step(0);
  s.scalars.emplace_back("time", 1.0);
  EXPECT_THROW(results.write_step(s), std::invalid_argument);
  EXPECT_EQ(results.steps_written(), 0);
}

TEST_F(ResultsOutput, FailedHdf5CallsThrowNamingTheCallTheObjectAndTheCause) {
  namespace h5 = yarnsim::output::h5;
  fs::create_directories(dir);
  h5::Handle file = h5::create_file(dir / "plain.h5");
  h5::Handle group = h5::create_group(file.id(), "steps/000000");
  const std::array<double, 2> values{1, 2};
  const std::array<hsize_t, 1> dims{2};
  h5::write_dataset(group.id(), "gap", values, dims);

  H5E_auto2_t print = nullptr;
  void* print_data = nullptr;
  H5Eget_auto2(H5E_DEFAULT, &print, &print_data);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); // keep the test's output clean
  try {
    h5::write_dataset(group.id(), "gap", values, dims);
    ADD_FAILURE() << "writing a dataset twice did not throw";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("H5Dcreate2"), std::string::npos) << what;
    EXPECT_NE(what.find("'gap'"), std::string::npos) << what;
    EXPECT_NE(what.find("plain.h5:/steps/000000"), std::string::npos) << what;
    EXPECT_NE(what.find("already exists"), std::string::npos) << what;
  }
  EXPECT_THROW(h5::create_file(dir / "no" / "such" / "dir.h5"), std::runtime_error);
  H5Eset_auto2(H5E_DEFAULT, print, print_data);
  const std::array<hsize_t, 1> wrong{3};
  EXPECT_THROW(h5::write_dataset(group.id(), "short", values, wrong), std::invalid_argument);
}

TEST_F(ResultsOutput, CsvHeaderAndEachRowAreOnDiskWhenTheCallReturns) {
  const fs::path path = dir / "monitors" / "tip.csv";
  CsvWriter csv(path, {"time [s]", "x [m]", "force [N]"});
  EXPECT_EQ(read_text(path), "time [s],x [m],force [N]\n");
  const std::vector<double> first{0.1, 1e-3, -2.5};
  csv.row(first);
  EXPECT_EQ(read_text(path), "time [s],x [m],force [N]\n0.1,0.001,-2.5\n");
  const std::vector<double> second{0.2, 1.0 / 3.0, 0};
  csv.row(second);
  EXPECT_EQ(read_text(path),
            "time [s],x [m],force [N]\n0.1,0.001,-2.5\n0.2,0.3333333333333333,0\n");
  const std::vector<double> short_row{0.3};
  EXPECT_THROW(csv.row(short_row), std::invalid_argument);
  EXPECT_THROW(CsvWriter(dir / "bad.csv", {"a,b"}), std::invalid_argument);
}

TEST_F(ResultsOutput, CsvRowOfNamedCellsIsWrittenAsGivenAndCountsAsARow) {
  const fs::path path = dir / "contact_points.csv";
  CsvWriter csv(path, {"increment [-]", "contact", "gap [m]"});
  const std::vector<std::string> cells{"3", "warp-weft", "-1e-06"};
  csv.row(cells);
  EXPECT_EQ(read_text(path), "increment [-],contact,gap [m]\n3,warp-weft,-1e-06\n");
  EXPECT_EQ(csv.rows(), 1);
  const std::vector<std::string> comma{"4", "a,b", "0"};
  EXPECT_THROW(csv.row(comma), std::invalid_argument);
  const std::vector<std::string> short_row{"4"};
  EXPECT_THROW(csv.row(short_row), std::invalid_argument);
  EXPECT_EQ(csv.rows(), 1);
}

#if defined(YARNSIM_SOURCE_DIR)
TEST_F(ResultsOutput, ParaViewOpensTheResultsWhileTheRunWrites) {
  if (std::system("command -v pvpython > /dev/null 2>&1") != 0) {
    // scripts/test installs python3-paraview and asks for the check: there it cannot skip.
    if (std::getenv("YARNSIM_REQUIRE_TEST_TOOLS") != nullptr)
      FAIL() << "pvpython not installed (python3-paraview), and YARNSIM_REQUIRE_TEST_TOOLS is set";
    GTEST_SKIP() << "pvpython not installed";
  }
  ResultsFile results(dir, drawn_mesh(), test_metadata(), std::chrono::milliseconds(0));
  results.write_step(test_step(0));
  results.write_step(test_step(2));
  const auto check = [&](const fs::path& xdmf, const std::string& label) {
    const fs::path log = dir / ("check-xdmf-" + label + ".log");
    const std::string command = std::string(YARNSIM_SOURCE_DIR) + "/scripts/check-xdmf " +
                                xdmf.string() + " > " + log.string() + " 2>&1";
    const int status = std::system(command.c_str());
    return std::pair{WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_text(log)};
  };
  const auto [status, out] = check(dir / "results.xdmf", "written");
  EXPECT_EQ(status, 0) << out;
  EXPECT_EQ(count(out, "time steps: 2"), 2u) << out; // once per reader

  // The check can fail: the same file with its heavy data in a file that does not exist, and
  // cut off in the middle of its XML.
  const std::string text = read_text(dir / "results.xdmf");
  ASSERT_NE(text.find("results.h5:"), std::string::npos);
  std::string moved = text;
  for (std::size_t at = moved.find("results.h5:"); at != std::string::npos;
       at = moved.find("results.h5:", at))
    moved.replace(at, 10, "missing.h5");
  std::ofstream(dir / "moved.xdmf") << moved;
  const auto [moved_status, moved_out] = check(dir / "moved.xdmf", "moved");
  EXPECT_EQ(moved_status, 1) << moved_out;
  std::ofstream(dir / "cut.xdmf") << text.substr(0, text.size() / 2);
  const auto [cut_status, cut_out] = check(dir / "cut.xdmf", "cut");
  EXPECT_EQ(cut_status, 1) << cut_out;
  // Yarn surfaces declared whose points cannot be read: the centre lines alone do not pass.
  std::string no_surface = text;
  for (std::size_t at = no_surface.find("/surface/points"); at != std::string::npos;
       at = no_surface.find("/surface/points", at))
    no_surface.replace(at, 15, "/surface/nothng");
  std::ofstream(dir / "no_surface.xdmf") << no_surface;
  const auto [surface_status, surface_out] = check(dir / "no_surface.xdmf", "no_surface");
  EXPECT_EQ(surface_status, 1) << surface_out;
  EXPECT_NE(surface_out.find("declares 'surfaces'"), std::string::npos) << surface_out;
}
#endif

// ---- going on with the files of an earlier run (a restart) ----

TEST_F(ResultsOutput, ContinuedFileKeepsTheCheckpointsStepsAndGoesOnAsAStraightRun) {
  const fs::path straight = dir / "straight";
  {
    ResultsFile results(straight, test_mesh(), test_metadata(), std::chrono::milliseconds(0));
    for (int k = 0; k < 4; ++k)
      results.write_step(test_step(k));
    results.close("completed", "4 steps");
  }
  const fs::path continued = dir / "continued";
  {
    ResultsFile results(continued, test_mesh(), test_metadata(), std::chrono::milliseconds(0));
    for (int k = 0; k < 3; ++k) // the third step was written after the checkpoint of the second
      results.write_step(test_step(k));
  }
  {
    ResultsFile results(continued, test_mesh(), test_metadata(), ResultsFile::Continue{2},
                        std::chrono::milliseconds(0));
    EXPECT_EQ(results.steps_written(), 2);
    for (int k = 2; k < 4; ++k)
      results.write_step(test_step(k));
    results.close("completed", "4 steps");
  }
  // The same XDMF text (the scalars in their order, not by name), the same steps.
  EXPECT_EQ(read_text(continued / "results.xdmf"), read_text(straight / "results.xdmf"));
  const hid_t a = H5Fopen((straight / "results.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t b = H5Fopen((continued / "results.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(a, 0);
  ASSERT_GE(b, 0);
  for (int k = 0; k < 4; ++k)
    for (const char* name : {"positions", "rotations", "reaction_force", "section_moment",
                             "contacts/gap", "contacts/position"}) {
      const std::string path = "/steps/00000" + std::to_string(k) + "/" + name;
      const Array x = read_array(a, path), y = read_array(b, path);
      EXPECT_EQ(x.dims, y.dims) << path;
      EXPECT_EQ(x.values, y.values) << path;
    }
  EXPECT_EQ(H5Lexists(b, "/steps/000004", H5P_DEFAULT), 0);
  EXPECT_EQ(read_string_attribute(b, "status"), "completed");
  H5Fclose(a);
  H5Fclose(b);
}

TEST_F(ResultsOutput, SurfacesAndContactTubesAreWrittenPerStepAndListedInTheXdmf) {
  const Mesh mesh = drawn_mesh();
  {
    ResultsFile results(dir, mesh, test_metadata(), std::chrono::milliseconds(0));
    for (int k = 0; k < 2; ++k)
      results.write_step(test_step(k));
    results.close("completed", "2 steps");
  }
  const hid_t file = open_read_only(dir / "results.h5");
  ASSERT_GE(file, 0);
  constexpr int kRing = yarnsim::output::kRingPoints;
  // 2 segments per element, a quad per ring point between consecutive rings.
  const Array quads = read_array(file, "/mesh/surface_quads");
  ASSERT_EQ(quads.dims, (std::vector<hsize_t>{2 * kElements * kRing, 4}));
  // The first quad joins ring point 0 and 1 of node 0 to those of node 1.
  EXPECT_EQ(quads.values[0], 0);
  EXPECT_EQ(quads.values[1], 1);
  EXPECT_EQ(quads.values[2], kRing + 1);
  EXPECT_EQ(quads.values[3], kRing);
  const int circles = 3 * yarnsim::output::kTubeSamplesPerSegment + 1; // 5 nodes: 3 segments
  const Array tube_quads = read_array(file, "/mesh/contact_tube_quads");
  ASSERT_EQ(tube_quads.dims,
            (std::vector<hsize_t>{hsize_t((circles - 1) * yarnsim::output::kTubePoints), 4}));
  for (int k = 0; k < 2; ++k) {
    const std::string step = "/steps/00000" + std::to_string(k);
    const StepResults expected = test_step(k);
    const Array points = read_array(file, step + "/surface/points");
    ASSERT_EQ(points.dims, (std::vector<hsize_t>{kRing * kNodes, 3}));
    // Every ring point on its node's section, placed by the node's current triad.
    for (int i = 0; i < kNodes; ++i) {
      const Eigen::Matrix3d Q = Eigen::AngleAxisd(expected.rotations.col(i).norm(),
                                                  expected.rotations.col(i).normalized())
                                    .toRotationMatrix() *
                                mesh.reference_triads[i];
      const auto& section = mesh.node_sections[i];
      for (int r = 0; r < kRing; ++r) {
        const Eigen::Vector3d p(points.values.data() + 3 * (kRing * i + r));
        const Eigen::Vector3d y = Q.transpose() * (p - expected.positions.col(i));
        EXPECT_NEAR(y.z(), 0.0, 1e-9) << "node " << i << ", ring point " << r;
        EXPECT_NEAR(std::pow(std::abs(y.x() / section.a), section.exponent) +
                        std::pow(std::abs(y.y() / section.b), section.exponent),
                    1.0, 1e-5)
            << "node " << i << ", ring point " << r;
      }
      // Ring point 0 lies on section axis 1 at the semi-axis a.
      const Eigen::Vector3d p0(points.values.data() + 3 * kRing * i);
      EXPECT_LT((p0 - expected.positions.col(i) - section.a * Q.col(0)).norm(), 1e-9);
    }
    const Array tube = read_array(file, step + "/contact_tube/points");
    ASSERT_EQ(tube.dims,
              (std::vector<hsize_t>{hsize_t(circles * yarnsim::output::kTubePoints), 3}));
    // The nodes lie on a straight line, so is the spline: every tube point at the radius from it.
    const Eigen::Vector3d start = expected.positions.col(0);
    const Eigen::Vector3d axis = (expected.positions.col(kNodes - 1) - start).normalized();
    for (std::size_t j = 0; j < tube.values.size() / 3; ++j) {
      const Eigen::Vector3d d = Eigen::Vector3d(tube.values.data() + 3 * j) - start;
      EXPECT_NEAR((d - d.dot(axis) * axis).norm(), 1.5e-4, 1e-9) << "tube point " << j;
    }
  }
  H5Fclose(file);

  const std::string xml = read_text(dir / "results.xdmf");
  EXPECT_EQ(xml_nesting_error(xml), "");
  EXPECT_EQ(count(xml, "CollectionType=\"Temporal\""), 4u);
  EXPECT_EQ(count(xml, "<Grid Name=\"surfaces\" GridType=\"Uniform\""), 2u);
  EXPECT_EQ(count(xml, "<Grid Name=\"contact_tubes\" GridType=\"Uniform\""), 2u);
  EXPECT_NE(xml.find("TopologyType=\"Quadrilateral\" NumberOfElements=\"48\""), std::string::npos);
  EXPECT_NE(xml.find("Dimensions=\"60 3\" NumberType=\"Float\" Precision=\"4\" "
                     "Format=\"HDF\">results.h5:/steps/000001/surface/points"),
            std::string::npos);
}

TEST_F(ResultsOutput, DrawingMeshesThatDoNotMatchTheNodesAreRejected) {
  Mesh mesh = drawn_mesh();
  mesh.node_sections.pop_back();
  EXPECT_THROW(ResultsFile(dir, mesh, test_metadata()), std::invalid_argument);
  mesh = drawn_mesh();
  mesh.node_sections[1].exponent = 0;
  EXPECT_THROW(ResultsFile(dir, mesh, test_metadata()), std::invalid_argument);
  mesh = drawn_mesh();
  mesh.contact_tubes[0].nodes = {0, 1};
  EXPECT_THROW(ResultsFile(dir, mesh, test_metadata()), std::invalid_argument);
  mesh = drawn_mesh();
  mesh.contact_tubes[0].nodes.push_back(kNodes);
  EXPECT_THROW(ResultsFile(dir, mesh, test_metadata()), std::invalid_argument);
}

TEST_F(ResultsOutput, ContinuedFileWithSurfacesMatchesTheStraightRun) {
  const fs::path straight = dir / "straight";
  {
    ResultsFile results(straight, drawn_mesh(), test_metadata(), std::chrono::milliseconds(0));
    for (int k = 0; k < 3; ++k)
      results.write_step(test_step(k));
    results.close("completed", "3 steps");
  }
  const fs::path continued = dir / "continued";
  {
    ResultsFile results(continued, drawn_mesh(), test_metadata(), std::chrono::milliseconds(0));
    results.write_step(test_step(0));
  }
  {
    ResultsFile results(continued, drawn_mesh(), test_metadata(), ResultsFile::Continue{1},
                        std::chrono::milliseconds(0));
    for (int k = 1; k < 3; ++k)
      results.write_step(test_step(k));
    results.close("completed", "3 steps");
  }
  EXPECT_EQ(read_text(continued / "results.xdmf"), read_text(straight / "results.xdmf"));
}

TEST_F(ResultsOutput, ContinuingAFileWithFewerStepsOrAnotherMeshIsRefused) {
  {
    ResultsFile results(dir, test_mesh(), test_metadata());
    results.write_step(test_step(0));
  }
  EXPECT_THROW(ResultsFile(dir, test_mesh(), test_metadata(), ResultsFile::Continue{2}),
               std::runtime_error);
  Mesh other = test_mesh();
  other.reference_positions.conservativeResize(3, kNodes + 1);
  other.node_radius.conservativeResize(kNodes + 1);
  EXPECT_THROW(ResultsFile(dir, other, test_metadata(), ResultsFile::Continue{1}),
               std::invalid_argument);
  EXPECT_THROW(ResultsFile(dir / "missing", test_mesh(), test_metadata(), ResultsFile::Continue{0}),
               std::runtime_error);
}

TEST_F(ResultsOutput, ContinuedCsvKeepsItsRowsDropsLaterOnesAndAppends) {
  fs::create_directories(dir);
  const fs::path file = dir / "tip.csv";
  {
    CsvWriter csv(file, {"time [s]", "x [m]"});
    for (double t : {0.1, 0.2, 0.3})
      csv.row(std::vector<double>{t, 2 * t});
  }
  {
    // A half-written fourth row, as a killed run may leave.
    std::ofstream out(file, std::ios::app);
    out << "0.4,0.";
  }
  {
    CsvWriter csv(file, {"time [s]", "x [m]"}, 2);
    EXPECT_EQ(csv.rows(), 2);
    csv.row(std::vector<double>{0.3, 0.6});
    EXPECT_EQ(csv.rows(), 3);
  }
  EXPECT_EQ(read_text(file), "time [s],x [m]\n0.1,0.2\n0.2,0.4\n0.3,0.6\n");
  // The header is taken from the file when no columns are given.
  {
    CsvWriter csv(file, {}, 3);
    EXPECT_EQ(csv.columns(), 2u);
  }
  EXPECT_THROW(CsvWriter(file, {"time [s]", "y [m]"}, 1), std::runtime_error);
  EXPECT_THROW(CsvWriter(file, {"time [s]", "x [m]"}, 4), std::runtime_error);
  EXPECT_THROW(CsvWriter(dir / "missing.csv", {"time [s]"}, 0), std::runtime_error);
}

} // namespace
