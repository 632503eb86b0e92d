#include "socketsmith/geometry/mesh_io.h"

#include <gtest/gtest.h>

#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>

#include "socketsmith/core/errors.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "test_shapes.h"

namespace socketsmith::geometry {
namespace {

namespace fs = std::filesystem;
using test::error_message;
using test::LogCapture;
using test::make_cube;
using test::make_icosphere;
using test::TempDir;
using units::LengthUnit;

struct FormatCase {
  MeshFormat format;
  const char* file;
  const char* expected_info_format;
  double rel_tol;  // binary STL stores floats
};

const FormatCase kFormats[] = {
    {MeshFormat::StlBinary, "shape.stl", "stl-binary", 1e-6},
    {MeshFormat::StlAscii, "shape.stl", "stl-ascii", 1e-12},
    {MeshFormat::Obj, "shape.obj", "obj", 1e-12},
    {MeshFormat::PlyBinary, "shape.ply", "ply-binary", 1e-12},
    {MeshFormat::PlyAscii, "shape.ply", "ply-ascii", 1e-12},
};

TEST(MeshIo, every_format_round_trips_in_mm_and_m) {
  LogCapture quiet;
  TempDir dir;
  const TriMesh sphere = make_icosphere(0.06, 3, Vec3(0.01, -0.02, 0.3));
  const double volume = signed_volume(sphere);
  const Aabb box = bounding_box(sphere);
  for (const FormatCase& c : kFormats) {
    for (LengthUnit unit : {LengthUnit::Millimetre, LengthUnit::Metre}) {
      SCOPED_TRACE(std::string(c.expected_info_format) + " in " + units::to_string(unit));
      const fs::path p = dir / c.file;
      write_mesh(p, sphere, unit, c.format);
      MeshReadInfo info;
      MeshReadOptions opt;
      opt.unit = unit;
      const TriMesh back = read_mesh(p, opt, &info);
      EXPECT_EQ(info.format, c.expected_info_format);
      EXPECT_EQ(info.unit, unit);
      EXPECT_FALSE(info.unit_was_guessed);
      EXPECT_TRUE(info.warning.empty()) << info.warning;
      EXPECT_EQ(back.num_vertices(), sphere.num_vertices());
      EXPECT_EQ(back.num_triangles(), sphere.num_triangles());
      EXPECT_NEAR(signed_volume(back), volume, 10 * c.rel_tol * volume);
      const Aabb b = bounding_box(back);
      EXPECT_LT((b.min - box.min).norm(), 1e-6);
      EXPECT_LT((b.max - box.max).norm(), 1e-6);
      // Same triangles (after welding, vertex order follows first use).
      for (int t = 0; t < back.num_triangles(); t += 97) {
        for (int k = 0; k < 3; ++k) {
          EXPECT_LT((back.vertices[back.triangles[t][k]] - sphere.vertices[sphere.triangles[t][k]]).norm(),
                    c.rel_tol * 1.0)
              << "triangle " << t;
        }
      }
      EXPECT_TRUE(check_mesh(back).is_valid_closed_surface());
    }
  }
  // Nothing but the last file of each extension is left: writes are atomic (no temp files).
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) {
    ++files;
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
  }
  EXPECT_EQ(files, 3);
}

TEST(MeshIo, auto_format_follows_the_extension) {
  LogCapture quiet;
  TempDir dir;
  const TriMesh cube = make_cube(0.1);
  const std::pair<const char*, const char*> cases[] = {
      {"a.stl", "stl-binary"}, {"b.STL", "stl-binary"}, {"c.obj", "obj"}, {"d.ply", "ply-binary"}};
  for (const auto& [name, format] : cases) {
    write_mesh(dir / name, cube);
    MeshReadInfo info;
    read_mesh(dir / name, {}, &info);
    EXPECT_EQ(info.format, format) << name;
  }
  const std::string msg = error_message<InvalidInputError>([&] { write_mesh(dir / "e.off", cube); });
  EXPECT_NE(msg.find("write_mesh"), std::string::npos) << msg;
  EXPECT_NE(msg.find(".off"), std::string::npos) << msg;
}

TEST(MeshIo, lengths_are_written_in_the_requested_unit_and_converted_to_metres) {
  LogCapture quiet;
  TempDir dir;
  const TriMesh cube = make_cube(0.1);  // 100 mm
  write_mesh(dir / "cube.obj", cube, LengthUnit::Millimetre);
  const std::string text = test::read_bytes(dir / "cube.obj");
  EXPECT_NE(text.find("v 100 100 100"), std::string::npos) << text;

  MeshReadOptions mm;
  mm.unit = LengthUnit::Millimetre;
  const TriMesh back = read_mesh(dir / "cube.obj", mm);
  EXPECT_TRUE(bounding_box(back).extent().isApprox(Vec3::Constant(0.1), 1e-12));
  EXPECT_NEAR(signed_volume(back), 1e-3, 1e-15);

  write_mesh(dir / "cube_m.obj", cube, LengthUnit::Metre);
  EXPECT_NE(test::read_bytes(dir / "cube_m.obj").find("v 0.1 0.1 0.1"), std::string::npos);
}

TEST(MeshIo, guesses_millimetres_or_metres_from_the_size_and_logs_it) {
  EXPECT_EQ(guess_length_unit(300.0), LengthUnit::Millimetre);
  EXPECT_EQ(guess_length_unit(5.1), LengthUnit::Millimetre);
  EXPECT_EQ(guess_length_unit(0.3), LengthUnit::Metre);
  EXPECT_EQ(guess_length_unit(5.0), LengthUnit::Metre);

  TempDir dir;
  const TriMesh limb = make_icosphere(0.08, 2);  // 0.16 m wide
  write_mesh(dir / "mm.stl", limb, LengthUnit::Millimetre);
  write_mesh(dir / "m.stl", limb, LengthUnit::Metre);
  {
    LogCapture log;
    MeshReadInfo info;
    const TriMesh a = read_mesh(dir / "mm.stl", {}, &info);
    EXPECT_TRUE(info.unit_was_guessed);
    EXPECT_EQ(info.unit, LengthUnit::Millimetre);
    EXPECT_TRUE(log.contains(log::Level::Info, "millimetres")) << (log.messages.empty() ? "" : log.messages[0].second);
    EXPECT_TRUE(log.contains(log::Level::Info, "mm.stl"));
    EXPECT_NEAR(bounding_box(a).extent().x(), bounding_box(limb).extent().x(), 1e-6);
  }
  {
    LogCapture log;
    MeshReadInfo info;
    const TriMesh b = read_mesh(dir / "m.stl", {}, &info);
    EXPECT_TRUE(info.unit_was_guessed);
    EXPECT_EQ(info.unit, LengthUnit::Metre);
    EXPECT_TRUE(log.contains(log::Level::Info, "metres"));
    EXPECT_TRUE(info.warning.empty());
    EXPECT_NEAR(signed_volume(b), signed_volume(limb), 1e-5 * signed_volume(limb));
  }
}

TEST(MeshIo, warns_when_the_declared_unit_gives_an_implausible_size) {
  TempDir dir;
  const TriMesh limb = make_cube(0.26);
  write_mesh(dir / "limb.stl", limb, LengthUnit::Millimetre);  // file says 260
  LogCapture log;
  MeshReadOptions as_metres;
  as_metres.unit = LengthUnit::Metre;
  MeshReadInfo info;
  read_mesh(dir / "limb.stl", as_metres, &info);
  EXPECT_NE(info.warning.find("limb.stl"), std::string::npos) << info.warning;
  EXPECT_NE(info.warning.find("is it in millimetres? (give the unit: limb.units \"mm\" in a case file, --units mm on the command line)"), std::string::npos) << info.warning;
  EXPECT_NE(info.warning.find("450 m across"), std::string::npos) << info.warning;  // diagonal 260*sqrt(3)
  EXPECT_TRUE(log.contains(log::Level::Warn, "is it in millimetres?"));

  // A tiny object declared in millimetres suggests metres.
  write_mesh(dir / "small.stl", limb, LengthUnit::Metre);  // file says 0.26
  MeshReadOptions as_mm;
  as_mm.unit = LengthUnit::Millimetre;
  read_mesh(dir / "small.stl", as_mm, &info);
  EXPECT_NE(info.warning.find("is it in metres? (give the unit: limb.units \"m\" in a case file, --units m on the command line)"), std::string::npos) << info.warning;

  as_mm.warn_on_implausible_size = false;
  read_mesh(dir / "small.stl", as_mm, &info);
  EXPECT_TRUE(info.warning.empty());
}

TEST(MeshIo, binary_stl_is_welded_to_shared_vertices) {
  LogCapture quiet;
  TempDir dir;
  write_mesh(dir / "cube.stl", make_cube(0.1), LengthUnit::Millimetre);
  EXPECT_EQ(fs::file_size(dir / "cube.stl"), 84u + 50u * 12u);
  MeshReadInfo info;
  const TriMesh m = read_mesh(dir / "cube.stl", {}, &info);
  EXPECT_EQ(m.num_vertices(), 8);
  EXPECT_EQ(m.num_triangles(), 12);
  EXPECT_EQ(info.welded_vertices, 36 - 8);
  EXPECT_EQ(info.dropped_triangles, 0);
  EXPECT_TRUE(check_mesh(m).is_valid_closed_surface());
}

TEST(MeshIo, binary_stl_whose_header_starts_with_solid_is_read_as_binary) {
  LogCapture quiet;
  TempDir dir;
  const fs::path p = dir / "tricky.stl";
  write_mesh(p, make_icosphere(0.05, 2), LengthUnit::Millimetre, MeshFormat::StlBinary);
  std::string bytes = test::read_bytes(p);
  const std::string header = "solid exported by a CAD tool that writes binary with a text header";
  std::memcpy(bytes.data(), header.data(), header.size());
  test::write_bytes(p, bytes);
  MeshReadInfo info;
  const TriMesh m = read_mesh(p, {}, &info);
  EXPECT_EQ(info.format, "stl-binary");
  EXPECT_EQ(m.num_triangles(), 320);
}

TEST(MeshIo, ascii_stl_with_several_solids_and_odd_spacing) {
  LogCapture quiet;
  TempDir dir;
  const fs::path p = dir / "two.stl";
  test::write_bytes(p,
                    "solid first part\r\n"
                    "facet normal 0 0 -1\r\n outer loop\r\n  vertex 0 0 0\r\n  vertex 0 10 0\r\n"
                    "  vertex +10 0 0\r\n endloop\r\nendfacet\r\nendsolid first part\r\n"
                    "solid second\n\tfacet normal 0 0 0\n outer loop vertex 0 0 0 vertex 10 0 0 vertex 0 0 1e1\n"
                    " endloop endfacet\nendsolid\n");
  MeshReadOptions mm;
  mm.unit = LengthUnit::Millimetre;
  MeshReadInfo info;
  const TriMesh m = read_mesh(p, mm, &info);
  EXPECT_EQ(info.format, "stl-ascii");
  EXPECT_EQ(m.num_triangles(), 2);
  EXPECT_EQ(m.num_vertices(), 4);
  EXPECT_NEAR(bounding_box(m).extent().maxCoeff(), 0.01, 1e-15);
}

TEST(MeshIo, obj_faces_with_texture_and_normal_indices_negative_indices_and_quads) {
  LogCapture quiet;
  TempDir dir;
  const fs::path p = dir / "cube.obj";
  // A unit cube (in metres) as quads, with every face syntax OBJ allows.
  test::write_bytes(p,
                    "# cube\nmtllib cube.mtl\no cube\n"
                    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1 0.5 0.5 0.5\nv 1 1 1\n"
                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
                    "g bottom\nusemtl skin\ns off\n"
                    "f 1/1 3/2 4/3 2/4\n"
                    "f 5//1 6//1 8//1 7//1\n"
                    "f 1/1/1 2/2/1 6/3/1 5/4/1\n"
                    "f -6 -2 -1 -5\n"  // 3 7 8 4
                    "f 1 5 7 3\n"
                    "f 2 4 8 6\n");
  MeshReadOptions opt;
  opt.unit = LengthUnit::Metre;
  const TriMesh m = read_mesh(p, opt);
  EXPECT_EQ(m.num_vertices(), 8);
  EXPECT_EQ(m.num_triangles(), 12);
  EXPECT_NEAR(signed_volume(m), 1.0, 1e-12);
  EXPECT_TRUE(check_mesh(m).is_valid_closed_surface());
}

/// A PLY file by hand: float/double coordinates with extra properties, an extra element, and
/// faces with a uchar or int count and int/uint indices.
std::string ply_cube(const std::string& encoding, bool is_big_endian) {
  const TriMesh cube = make_cube(100.0);
  std::string h = "ply\nformat " + encoding +
                  " 1.0\ncomment made by hand\nobj_info test\nelement vertex 8\nproperty float x\n"
                  "property uchar red\nproperty double y\nproperty float z\nproperty list uchar int "
                  "extra_list\nelement edge 1\nproperty int vertex1\nproperty int vertex2\n"
                  "element face 6\nproperty int flags\nproperty list int uint vertex_indices\n"
                  "end_header\n";
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  if (encoding == "ascii") {
    for (const Vec3& v : cube.vertices)
      h += std::to_string(v.x()) + " 255 " + std::to_string(v.y()) + " " + std::to_string(v.z()) + " 2 7 8\n";
    h += "0 1\n";
    for (const auto& q : quads)
      h += "0 4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) + " " +
           std::to_string(q[3]) + "\n";
    return h;
  }
  auto put = [&](auto value) {
    char b[sizeof(value)];
    std::memcpy(b, &value, sizeof(value));
    if (is_big_endian == (std::endian::native == std::endian::little)) std::reverse(b, b + sizeof(value));
    h.append(b, sizeof(value));
  };
  for (const Vec3& v : cube.vertices) {
    put(static_cast<float>(v.x()));
    put(std::uint8_t{255});
    put(v.y());
    put(static_cast<float>(v.z()));
    put(std::uint8_t{2});
    put(std::int32_t{7});
    put(std::int32_t{8});
  }
  put(std::int32_t{0});
  put(std::int32_t{1});
  for (const auto& q : quads) {
    put(std::int32_t{0});
    put(std::int32_t{4});
    for (int k = 0; k < 4; ++k) put(static_cast<std::uint32_t>(q[k]));
  }
  return h;
}

TEST(MeshIo, ply_ascii_little_and_big_endian_with_extra_properties) {
  LogCapture quiet;
  TempDir dir;
  const std::pair<std::string, bool> encodings[] = {
      {"ascii", false}, {"binary_little_endian", false}, {"binary_big_endian", true}};
  for (const auto& [enc, big] : encodings) {
    SCOPED_TRACE(enc);
    const fs::path p = dir / ("cube_" + enc + ".ply");
    test::write_bytes(p, ply_cube(enc, big));
    MeshReadInfo info;
    const TriMesh m = read_mesh(p, {}, &info);
    EXPECT_EQ(info.format, enc == "ascii" ? "ply-ascii" : "ply-binary");
    EXPECT_EQ(info.unit, LengthUnit::Millimetre);  // 173 units across
    EXPECT_EQ(m.num_vertices(), 8);
    EXPECT_EQ(m.num_triangles(), 12);
    EXPECT_NEAR(signed_volume(m), 1e-3, 1e-12);
    EXPECT_TRUE(check_mesh(m).is_valid_closed_surface());
  }
}

/// Expects read_mesh(p) to throw E whose message names the function and the file and contains
/// @p needle.
template <class E>
void expect_read_error(const fs::path& p, const std::string& needle) {
  const std::string msg = error_message<E>([&] { read_mesh(p); });
  EXPECT_EQ(msg.rfind("read_mesh: ", 0), 0u) << msg;
  EXPECT_NE(msg.find("'" + p.string() + "'"), std::string::npos) << msg;
  EXPECT_NE(msg.find(needle), std::string::npos) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line: " << msg;
}

TEST(MeshIoErrors, missing_file_is_an_io_error) {
  TempDir dir;
  expect_read_error<IoError>(dir / "nope.stl", "cannot open");
  fs::create_directories(dir / "really_a_folder.stl");
  expect_read_error<IoError>(dir / "really_a_folder.stl", "directory");
}

TEST(MeshIoErrors, empty_files) {
  TempDir dir;
  for (const char* name : {"empty.stl", "empty.obj", "empty.ply"}) {
    test::write_bytes(dir / name, "");
    expect_read_error<InvalidInputError>(dir / name, "empty");
  }
  test::write_bytes(dir / "blank.obj", "\n \n\t\n");
  expect_read_error<InvalidInputError>(dir / "blank.obj", "whitespace");
}

TEST(MeshIoErrors, garbage_text) {
  TempDir dir;
  const std::string garbage = "Dear customer,\nthank you for your order of 3 socket liners.\n";
  test::write_bytes(dir / "g.stl", garbage);
  expect_read_error<InvalidInputError>(dir / "g.stl", "not an STL file");
  test::write_bytes(dir / "g.obj", garbage);
  expect_read_error<InvalidInputError>(dir / "g.obj", "no 'v' or 'f' lines");
  test::write_bytes(dir / "g.ply", garbage);
  expect_read_error<InvalidInputError>(dir / "g.ply", "not a PLY file");
  test::write_bytes(dir / "solid.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 1 2 abc\n");
  expect_read_error<InvalidInputError>(dir / "solid.stl", "line 4");
  test::write_bytes(dir / "bad.obj", "v 1 2 3\nv 1 x 3\n");
  expect_read_error<InvalidInputError>(dir / "bad.obj", "line 2");
  std::string binary_garbage(1000, '\0');
  for (std::size_t i = 0; i < binary_garbage.size(); ++i) binary_garbage[i] = static_cast<char>(i * 7919 % 251);
  test::write_bytes(dir / "b.obj", binary_garbage);
  expect_read_error<InvalidInputError>(dir / "b.obj", "binary");
  test::write_bytes(dir / "x.off", "OFF\n");
  expect_read_error<InvalidInputError>(dir / "x.off", "unsupported extension");
  // A folder given as a mesh is named as such (it said "unsupported extension ''").
  std::filesystem::create_directories(dir / "scans");
  expect_read_error<IoError>(dir / "scans", "it is a directory");
}

// Found by fuzz_ply (UBSan: "1.75905e+22 is outside the range of representable values of type
// 'long long'"): a list count stored as a float was cast to an integer unchecked.
TEST(MeshIoErrors, a_binary_ply_count_stored_as_a_float_must_be_a_sane_whole_number) {
  LogCapture quiet;
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list float int vertex_indices\nend_header\n";
  std::string body(9 * sizeof(float), '\0');
  const float vertices[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  std::memcpy(body.data(), vertices, sizeof vertices);
  const auto with_count = [&](float count) {
    std::string face(sizeof(float) + 3 * sizeof(std::int32_t), '\0');
    const std::int32_t idx[3] = {0, 1, 2};
    std::memcpy(face.data(), &count, sizeof count);
    std::memcpy(face.data() + sizeof count, idx, sizeof idx);
    return header + body + face;
  };
  EXPECT_EQ(read_mesh_data(with_count(3.0f), "ok.ply").num_triangles(), 1);
  for (const float bad : {1.75905e22f, 2.5f, std::numeric_limits<float>::quiet_NaN()}) {
    try {
      read_mesh_data(with_count(bad), "bad.ply");
      ADD_FAILURE() << "no error for a count of " << bad;
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find("stored as a float"), std::string::npos) << e.what();
    }
  }
}

// Found by fuzz_ply (a libFuzzer timeout): an element of 8e14 items without properties was looped
// over item by item (the header's size check bounds every other count). It carries no data.
TEST(MeshIoErrors, a_ply_element_without_properties_is_not_looped_over) {
  LogCapture quiet;
  const std::string tetra =
      "element vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 4\n"
      "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n"
      "3 0 3 2\n3 1 2 3\n";
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(read_mesh_data("ply\nformat ascii 1.0\nelement marker 800000041468615\n" + tetra, "m.ply").num_triangles(), 4);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
}

TEST(MeshIoErrors, truncated_binary_files) {
  LogCapture quiet;
  TempDir dir;
  const TriMesh s = make_icosphere(0.05, 2);
  write_mesh(dir / "s.stl", s);
  std::string bytes = test::read_bytes(dir / "s.stl");
  test::write_bytes(dir / "cut.stl", bytes.substr(0, bytes.size() - 10));
  expect_read_error<InvalidInputError>(dir / "cut.stl", "truncated");
  test::write_bytes(dir / "tiny.stl", bytes.substr(0, 83));
  expect_read_error<InvalidInputError>(dir / "tiny.stl", "truncated");

  write_mesh(dir / "s.ply", s);
  bytes = test::read_bytes(dir / "s.ply");
  test::write_bytes(dir / "cut.ply", bytes.substr(0, bytes.size() - 5));
  expect_read_error<InvalidInputError>(dir / "cut.ply", "truncated");
  write_mesh(dir / "a.ply", s, LengthUnit::Millimetre, MeshFormat::PlyAscii);
  bytes = test::read_bytes(dir / "a.ply");
  test::write_bytes(dir / "cut_ascii.ply", bytes.substr(0, bytes.size() / 2));
  expect_read_error<InvalidInputError>(dir / "cut_ascii.ply", "truncated");
  test::write_bytes(dir / "header_only.ply", "ply\nformat ascii 1.0\nelement vertex 3\n");
  expect_read_error<InvalidInputError>(dir / "header_only.ply", "end_header");
}

TEST(MeshIoErrors, zero_triangles) {
  TempDir dir;
  std::string header(84, '\0');
  header.replace(0, 5, "hello");
  test::write_bytes(dir / "zero.stl", header);
  expect_read_error<InvalidInputError>(dir / "zero.stl", "0 triangles");
  test::write_bytes(dir / "ascii_zero.stl", "solid nothing\nendsolid nothing\n");
  expect_read_error<InvalidInputError>(dir / "ascii_zero.stl", "0 triangles");
  test::write_bytes(dir / "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  expect_read_error<InvalidInputError>(dir / "points.obj", "0 triangles");
  test::write_bytes(dir / "points.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                        "property float y\nproperty float z\nend_header\n1 2 3\n");
  expect_read_error<InvalidInputError>(dir / "points.ply", "0 triangles");
}

TEST(MeshIoErrors, non_finite_coordinates) {
  TempDir dir;
  test::write_bytes(dir / "nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_read_error<InvalidInputError>(dir / "nan.obj", "non-finite");
  test::write_bytes(dir / "inf.stl",
                    "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex inf 0 0\nvertex 0 1 0\n"
                    "endloop\nendfacet\nendsolid s\n");
  expect_read_error<InvalidInputError>(dir / "inf.stl", "non-finite");

  LogCapture quiet;
  write_mesh(dir / "b.stl", make_cube(0.1));
  std::string bytes = test::read_bytes(dir / "b.stl");
  const float nan = std::nanf("");
  std::memcpy(bytes.data() + 84 + 50 * 5 + 12 + 4, &nan, 4);  // triangle 5, vertex 0, y
  test::write_bytes(dir / "b.stl", bytes);
  expect_read_error<InvalidInputError>(dir / "b.stl", "triangle 5 has a non-finite coordinate");

  test::write_bytes(dir / "nan.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                     "end_header\n0 0 0\n1 0 0\n0 NaN 0\n3 0 1 2\n");
  expect_read_error<InvalidInputError>(dir / "nan.ply", "vertex 2 has a non-finite coordinate");
}

TEST(MeshIoErrors, index_out_of_range) {
  TempDir dir;
  test::write_bytes(dir / "oob.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n");
  expect_read_error<InvalidInputError>(dir / "oob.obj", "vertex 9 but the file has 3 vertices");
  test::write_bytes(dir / "neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
  expect_read_error<InvalidInputError>(dir / "neg.obj", "out of range");
  test::write_bytes(dir / "zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
  expect_read_error<InvalidInputError>(dir / "zero.obj", "start at 1");
  test::write_bytes(dir / "oob.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                     "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                     "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
  expect_read_error<InvalidInputError>(dir / "oob.ply", "refers to vertex 3 but the file has 3 vertices");
}

TEST(MeshIoErrors, corrupted_files_raise_errors_never_crash) {
  // Random byte edits, truncations and insertions: read_mesh either succeeds or throws a
  // socketsmith::Error (no crash, no std::bad_alloc from a corrupt count).
  test::LogCapture quiet;
  TempDir dir;
  const TriMesh s = make_icosphere(0.05, 1);
  const std::pair<const char*, MeshFormat> cases[] = {{"a.stl", MeshFormat::StlBinary},
                                                      {"b.stl", MeshFormat::StlAscii},
                                                      {"c.obj", MeshFormat::Obj},
                                                      {"d.ply", MeshFormat::PlyBinary},
                                                      {"e.ply", MeshFormat::PlyAscii}};
  std::mt19937 rng(2024);
  int errors = 0;
  for (const auto& [name, format] : cases) {
    write_mesh(dir / name, s, LengthUnit::Millimetre, format);
    const std::string original = test::read_bytes(dir / name);
    for (int it = 0; it < 150; ++it) {
      std::string b = original;
      for (int k = 0, n = 1 + static_cast<int>(rng() % 6); k < n && !b.empty(); ++k) {
        const std::size_t pos = rng() % b.size();
        switch (rng() % 4) {
          case 0: b[pos] = static_cast<char>(rng()); break;
          case 1: b.resize(pos); break;
          case 2: b.insert(pos, 1, " 0123456789-e.\n/#nanf"[rng() % 21]); break;
          default:
            if (pos + 4 <= b.size()) {
              const std::uint32_t v = static_cast<std::uint32_t>(rng());
              std::memcpy(&b[pos], &v, 4);
            }
        }
      }
      const fs::path p = dir / (std::string("corrupt_") + name);
      test::write_bytes(p, b);
      try {
        const TriMesh m = read_mesh(p);
        check_mesh(m);
      } catch (const Error& e) {
        ++errors;
        EXPECT_EQ(std::string(e.what()).rfind("read_mesh: ", 0), 0u) << e.what();
      }
    }
  }
  EXPECT_GT(errors, 100);  // the edits do break files
}

TEST(MeshIo, degenerate_faces_are_dropped_and_counted) {
  LogCapture quiet;
  TempDir dir;
  test::write_bytes(dir / "d.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 2\n");
  MeshReadInfo info;
  const TriMesh m = read_mesh(dir / "d.obj", {}, &info);
  EXPECT_EQ(m.num_triangles(), 1);
  EXPECT_EQ(info.dropped_triangles, 1);
  test::write_bytes(dir / "all.obj", "v 0 0 0\nv 1 0 0\nf 1 1 2\n");
  expect_read_error<InvalidInputError>(dir / "all.obj", "degenerate");
}

TEST(MeshIo, write_rejects_bad_meshes) {
  TempDir dir;
  TriMesh m = make_cube();
  m.triangles[0][0] = 42;
  EXPECT_THROW(write_mesh(dir / "x.stl", m), InvalidInputError);
  m = make_cube();
  m.vertices[0].x() = std::nan("");
  EXPECT_THROW(write_mesh(dir / "x.stl", m), InvalidInputError);
  EXPECT_FALSE(fs::exists(dir / "x.stl"));
}

}  // namespace
}  // namespace socketsmith::geometry
