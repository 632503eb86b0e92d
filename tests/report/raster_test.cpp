#include "socketsmith/report/raster.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "socketsmith/core/errors.h"

// The reader is only needed here, to check what write_png wrote.
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

namespace fs = std::filesystem;
using socketsmith::InvalidInputError;
using socketsmith::IoError;
using socketsmith::geometry::Aabb;
using socketsmith::geometry::bounding_box;
using socketsmith::geometry::TriMesh;
using socketsmith::geometry::Vec3;
using namespace socketsmith::report;

namespace {

constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kBlack{0, 0, 0};
constexpr Rgb kRed{255, 0, 0};
constexpr Rgb kBlue{0, 0, 255};

/// Axis-aligned cube [-h, h]^3, counter-clockwise seen from outside.
TriMesh cube(double h = 0.5) {
  TriMesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back(i & 1 ? h : -h, i & 2 ? h : -h, i & 4 ? h : -h);
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

/// Square [-h, h]^2 at height z, two triangles facing +z.
TriMesh square(double z, double h = 0.5) {
  TriMesh m;
  m.vertices = {{-h, -h, z}, {h, -h, z}, {h, h, z}, {-h, h, z}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

/// One triangle at height z facing +z, covering the centre of [-1, 1]^2.
TriMesh triangle(double z) {
  TriMesh m;
  m.vertices = {{-0.8, -0.8, z}, {0.8, -0.8, z}, {0.0, 0.8, z}};
  m.triangles = {{0, 1, 2}};
  return m;
}

Aabb box(double h) {
  Aabb b;
  b.extend(Vec3::Constant(-h));
  b.extend(Vec3::Constant(h));
  return b;
}

MeshLayer layer(const TriMesh& mesh, Rgb colour, double opacity = 1.0) {
  MeshLayer l;
  l.mesh = &mesh;
  l.colour = colour;
  l.opacity = opacity;
  return l;
}

/// Renders into a fresh white n × n image filling it, camera on +z unless given.
Image draw(const std::vector<MeshLayer>& layers, const std::vector<Marker>& markers = {},
           const Aabb& frame = box(1), Camera cam = {}, int n = 100) {
  Image img(n, n, kWhite);
  render(img, cam, layers, markers, 0, 0, n, n, frame);
  return img;
}

void expect_near(Rgb actual, Rgb expected, int tol = 1) {
  EXPECT_NEAR(actual.r, expected.r, tol);
  EXPECT_NEAR(actual.g, expected.g, tol);
  EXPECT_NEAR(actual.b, expected.b, tol);
}

}  // namespace

TEST(Raster,
     unit_cube_seen_from_plus_z_shows_its_colour_at_the_centre_and_background_at_the_corners) {
  const TriMesh c = cube();
  const Rgb colour{200, 100, 50};
  Image img(200, 200, kWhite);
  render(img, Camera{}, {layer(c, colour)}, {}, 0, 0, 200, 200, bounding_box(c));
  // The face toward the headlight is lit face-on: its true colour.
  expect_near(img.at(100, 100), colour);
  expect_near(img.at(20, 180), colour);
  for (auto [x, y] : {std::pair{0, 0}, {199, 0}, {0, 199}, {199, 199}, {5, 100}})
    EXPECT_EQ(img.at(x, y), kWhite) << x << ", " << y;
}

TEST(Raster, stack_images_puts_them_one_below_the_other_on_the_background) {
  const Image a(4, 2, {255, 0, 0}), b(6, 3, {0, 0, 255});
  const Image s = stack_images({a, b}, {9, 9, 9});
  ASSERT_EQ(s.width, 6);
  ASSERT_EQ(s.height, 5);
  EXPECT_EQ(s.at(3, 1).r, 255);  // a
  EXPECT_EQ(s.at(5, 1).r, 9);    // right of a: background
  EXPECT_EQ(s.at(5, 4).b, 255);  // b
  EXPECT_THROW(stack_images({}), InvalidInputError);
}

TEST(Raster, near_triangle_hides_far_one_in_either_draw_order) {
  const TriMesh near = triangle(0.1), far = triangle(-0.1);
  for (bool near_first : {true, false}) {
    std::vector<MeshLayer> layers{layer(near, kRed), layer(far, kBlue)};
    if (!near_first) std::swap(layers[0], layers[1]);
    expect_near(draw(layers).at(50, 50), kRed);
  }
  // Seen from -z the blue one is in front.
  const Camera from_below{Vec3(0, 0, 1), Vec3(0, 1, 0)};
  const Image img = draw({layer(near, kRed), layer(far, kBlue)}, {}, box(1), from_below);
  EXPECT_GT(img.at(50, 50).b, 100);
  EXPECT_EQ(img.at(50, 50).r, 0);
}

TEST(Raster, vertex_values_map_to_the_colormap_ends_and_clamp) {
  const TriMesh sq = square(0);
  for (Colormap map : {Colormap::Viridis, Colormap::Pressure, Colormap::Greys}) {
    MeshLayer l = layer(sq, kWhite);
    l.colormap = map;
    l.value_min = 10;
    l.value_max = 20;
    l.vertex_values.assign(4, 3.0);  // below the range: clamps to the start
    expect_near(draw({l}).at(50, 50), colormap_colour(map, 0));
    l.vertex_values.assign(4, 20.0);
    expect_near(draw({l}).at(50, 50), colormap_colour(map, 1));
  }
  // A gradient from value_min (left) to value_max (right) on two large triangles: the value is
  // interpolated, not the corner colours, so the middle shows the colormap's middle (green–
  // yellow for Pressure), not a blue–red blend.
  const TriMesh wide = square(0, 0.9);  // pixels 9.5 .. 90.5
  MeshLayer l = layer(wide, kWhite);
  l.colormap = Colormap::Pressure;
  l.vertex_values = {0, 1, 1, 0};
  const Image img = draw({l});
  expect_near(img.at(10, 50), colormap_colour(Colormap::Pressure, 0.0), 8);
  expect_near(img.at(89, 50), colormap_colour(Colormap::Pressure, 1.0), 8);
  expect_near(img.at(50, 50), colormap_colour(Colormap::Pressure, 0.5), 6);
  // A non-finite value is drawn in the layer colour ("no data").
  l.vertex_values.assign(4, std::numeric_limits<double>::quiet_NaN());
  expect_near(draw({l}).at(50, 50), kWhite);
}

TEST(Raster, colormaps_run_from_their_named_start_to_their_named_end) {
  const Rgb low = colormap_colour(Colormap::Pressure, 0),
            high = colormap_colour(Colormap::Pressure, 1);
  EXPECT_GT(low.b, 2 * low.r);    // blue
  EXPECT_GT(high.r, 2 * high.b);  // red
  const Rgb mid = colormap_colour(Colormap::Pressure, 0.5);
  EXPECT_GT(mid.g, mid.b);  // between green and yellow
  const Rgb dark = colormap_colour(Colormap::Greys, 0), light = colormap_colour(Colormap::Greys, 1);
  EXPECT_LT(dark.r, 50);
  EXPECT_GT(light.r, 200);
  EXPECT_EQ(colormap_colour(Colormap::Viridis, -1), colormap_colour(Colormap::Viridis, 0));
  EXPECT_EQ(colormap_colour(Colormap::Viridis, 7), colormap_colour(Colormap::Viridis, 1));
}

TEST(Raster, marker_behind_a_surface_is_hidden_unless_forced) {
  const TriMesh c = cube();
  const Rgb green{0, 255, 0};
  Marker inside{Vec3::Zero(), "", green};
  expect_near(draw({layer(c, kBlack)}, {inside}).at(50, 50), kBlack);
  inside.is_always_visible = true;
  expect_near(draw({layer(c, kBlack)}, {inside}).at(50, 50), green);
  // A landmark on the visible face shows without the flag.
  const Marker on_face{Vec3(0, 0, 0.5), "tip", green};
  expect_near(draw({layer(c, kBlack)}, {on_face}).at(50, 50), green);
  // Translucent layers do not hide markers.
  expect_near(draw({layer(c, kBlack, 0.5)}, {Marker{Vec3::Zero(), "", green}}).at(50, 50), green);
}

TEST(Raster, marker_label_is_drawn_beside_the_disc) {
  const Image plain = draw({}, {Marker{Vec3::Zero(), "", kRed}});
  const Image labelled = draw({}, {Marker{Vec3::Zero(), "TIP", kRed}});
  int changed_right = 0;
  for (int y = 40; y < 60; ++y)
    for (int x = 60; x < 100; ++x) changed_right += !(plain.at(x, y) == labelled.at(x, y));
  EXPECT_GT(changed_right, 20);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 45; ++x) EXPECT_EQ(plain.at(x, y), labelled.at(x, y));
  // Near the right edge the label goes to the left of the disc.
  const Image edge = draw({}, {Marker{Vec3(0.9, 0, 0), "TIP", kRed}});
  int changed_left = 0;
  for (int y = 40; y < 60; ++y)
    for (int x = 40; x < 85; ++x) changed_left += !(edge.at(x, y) == kWhite);
  EXPECT_GT(changed_left, 20);
}

TEST(Raster, labels_of_markers_close_together_do_not_cover_each_other) {
  // Four landmarks within two pixels of each other (a transfemoral socket's IS, IR, AL and ST
  // under the medial brim): each label gets its own rows beside the cluster.
  const std::vector<Marker> cluster{Marker{Vec3::Zero(), "AB", kRed}, Marker{Vec3(0.01, 0, 0), "CD", kRed},
                                    Marker{Vec3(0, 0.01, 0), "EF", kRed}, Marker{Vec3(0.01, 0.01, 0), "GH", kRed}};
  const Image img = draw({}, cluster);
  // Rows right of the discs (x 60..99) holding label ink, grouped into bands of consecutive rows.
  std::vector<int> bands;
  bool in_band = false;
  for (int y = 0; y < 100; ++y) {
    bool ink = false;
    for (int x = 60; x < 100; ++x) ink = ink || img.at(x, y).r < 100;
    if (ink && !in_band) bands.push_back(y);
    in_band = ink;
  }
  EXPECT_EQ(bands.size(), 4u);
  // One marker alone keeps its label at its own height.
  const Image one = draw({}, {cluster[0]});
  int rows = 0;
  for (int y = 40; y < 60; ++y)
    for (int x = 60; x < 100; ++x) rows += one.at(x, y).r < 100 ? 1 : 0;
  EXPECT_GT(rows, 10);
}

TEST(Raster, back_faces_are_darker_and_translucent_layers_blend_over_opaque_ones) {
  const TriMesh t = triangle(0);
  const Rgb grey{200, 200, 200};
  const Camera from_below{Vec3(0, 0, 1), Vec3(0, 1, 0)};
  expect_near(draw({layer(t, grey)}).at(50, 50), grey);
  expect_near(draw({layer(t, grey)}, {}, box(1), from_below).at(50, 50), Rgb{120, 120, 120});

  // Translucent white in front of opaque red: half and half. Behind it: hidden.
  const TriMesh front = square(0.2, 0.9), back = triangle(0);
  expect_near(draw({layer(front, kWhite, 0.5), layer(back, kRed)}).at(50, 50), Rgb{255, 128, 128});
  const TriMesh behind = square(-0.2, 0.9);
  expect_near(draw({layer(behind, kWhite, 0.5), layer(back, kRed)}).at(50, 50), kRed);
}

TEST(Raster, translucent_square_has_no_seam_along_its_shared_diagonal) {
  const TriMesh sq = square(0);
  Image img(100, 100, kBlack);
  render(img, Camera{}, {layer(sq, kWhite, 0.5)}, {}, 0, 0, 100, 100, box(0.5),
         {.margin = 0.1, .supersampling = 1});
  // Every pixel inside the square is blended exactly once.
  for (int y = 12; y < 88; ++y)
    for (int x = 12; x < 88; ++x) ASSERT_EQ(img.at(x, y), (Rgb{128, 128, 128})) << x << ", " << y;
}

TEST(Raster, render_touches_only_its_viewport) {
  const TriMesh c = cube();
  Image img(300, 100, kWhite);
  render(img, Camera{}, {layer(c, kRed)}, {Marker{Vec3(0.5, 0.5, 0.5), "corner label", kBlue}}, 100,
         0, 100, 100, bounding_box(c));
  for (int y = 0; y < 100; ++y)
    for (int x : {0, 50, 99, 200, 250, 299}) EXPECT_EQ(img.at(x, y), kWhite);
  expect_near(img.at(150, 50), kRed);
}

TEST(Raster, fit_frames_the_box_within_the_margin) {
  const Camera oblique{Vec3(-1, -2, -0.5), Vec3(0, 0, 1)};
  const Aabb b = bounding_box(cube(0.3));
  const Projection p = fit(oblique, b, 40, 10, 200, 100, 0.1);
  double xmin = 1e9, xmax = -1e9, ymin = 1e9, ymax = -1e9;
  for (const Vec3& v : cube(0.3).vertices) {
    const Vec3 q = p.project(v);
    xmin = std::min(xmin, q.x()), xmax = std::max(xmax, q.x());
    ymin = std::min(ymin, q.y()), ymax = std::max(ymax, q.y());
  }
  // 10 px border: the height limits, so the box touches the top and bottom border.
  EXPECT_NEAR(ymin, 20, 1e-9);
  EXPECT_NEAR(ymax, 100, 1e-9);
  EXPECT_NEAR(0.5 * (xmin + xmax), 140, 1e-9);
  EXPECT_GE(xmin, 50);
  EXPECT_LE(xmax, 230);
  // Up on screen is world +z; the view direction points away from the eye.
  EXPECT_LT(p.project(Vec3(0, 0, 1)).y(), p.project(Vec3::Zero()).y());
  EXPECT_GT(p.project(Vec3(-1, -2, -0.5)).z(), 0);
}

TEST(Raster, a_fixed_scale_overrides_the_fit) {
  const TriMesh c = cube();  // 1 m wide: 40 px at 40 px/m, centred
  Image img(100, 100, kWhite);
  render(img, Camera{}, {layer(c, kRed)}, {}, 0, 0, 100, 100, bounding_box(c),
         {.scale_px_per_m = 40});
  expect_near(img.at(31, 50), kRed);
  expect_near(img.at(68, 50), kRed);
  EXPECT_EQ(img.at(28, 50), kWhite);
  EXPECT_EQ(img.at(71, 50), kWhite);
}

TEST(Raster, text_and_colour_bar_draw_where_asked) {
  Image img(200, 120, kWhite);
  draw_text(img, 10, 10, "Hi 42", kBlack, 2);
  const int w = text_width("Hi 42", 2), h = text_height("Hi 42", 2);
  EXPECT_EQ(h, 24);
  int inked = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 200; ++x)
      if (img.at(x, y) == kBlack) {
        ++inked;
        EXPECT_TRUE(x >= 10 && x < 10 + w && y >= 10 && y < 10 + h) << x << ", " << y;
      }
  EXPECT_GT(inked, 40);
  // Non-ASCII bytes do not crash the bitmap font.
  draw_text(img, 0, 100, "\xC2\xB5m \t", kBlack, 1);

  Image bar(120, 140, kWhite);
  draw_colour_bar(bar, 10, 30, 16, 100, Colormap::Pressure, 0, 250, "kPa");
  expect_near(bar.at(18, 30), colormap_colour(Colormap::Pressure, 1), 4);
  expect_near(bar.at(18, 129), colormap_colour(Colormap::Pressure, 0), 4);
}

TEST(Raster, render_views_lays_out_views_captions_title_and_colour_bar) {
  const TriMesh c = cube();
  const std::vector<std::pair<Camera, std::string>> views{
      {Camera{}, "front"}, {Camera{Vec3(-1, 0, 0), Vec3(0, 1, 0)}, "side"}};
  const Image plain = render_views({layer(c, kRed)}, {}, views, 120, "Cube");
  EXPECT_EQ(plain.width, 240);
  MeshLayer valued = layer(c, kRed);
  valued.vertex_values.assign(8, 1.0);
  valued.value_label = "kPa";
  const Image with_bar = render_views({valued}, {}, views, 120, "Cube");
  EXPECT_GT(with_bar.width, 240);
  EXPECT_EQ(with_bar.height, plain.height);
  EXPECT_GT(plain.height, 120 + 40);
}

TEST(Raster, png_round_trip_keeps_size_and_pixels) {
  const fs::path dir =
      fs::temp_directory_path() / ("socketsmith_raster_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  Image img(37, 23, Rgb{10, 20, 30});
  img.at(0, 0) = kRed;
  img.at(36, 22) = kBlue;
  img.at(5, 17) = Rgb{1, 2, 3};
  const fs::path path = dir / "round.png";
  write_png(path, img);
  int w = 0, h = 0, comp = 0;
  unsigned char* data = stbi_load(path.string().c_str(), &w, &h, &comp, 3);
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(w, 37);
  EXPECT_EQ(h, 23);
  EXPECT_EQ(comp, 3);
  auto pixel = [&](int x, int y) {
    const unsigned char* p = data + 3 * (y * w + x);
    return Rgb{p[0], p[1], p[2]};
  };
  EXPECT_EQ(pixel(0, 0), kRed);
  EXPECT_EQ(pixel(36, 22), kBlue);
  EXPECT_EQ(pixel(5, 17), (Rgb{1, 2, 3}));
  EXPECT_EQ(pixel(20, 10), (Rgb{10, 20, 30}));
  stbi_image_free(data);
  // Only the PNG is left behind (no temporary file).
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  fs::remove_all(dir);
}

TEST(Raster, bad_input_throws_and_draws_nothing) {
  EXPECT_THROW(Image(0, 10, kWhite), InvalidInputError);
  EXPECT_THROW(Image(10, -1, kWhite), InvalidInputError);

  const TriMesh c = cube();
  Image img(50, 50, kWhite);
  const Aabb b = bounding_box(c);
  EXPECT_THROW(render(img, Camera{}, {layer(c, kRed)}, {}, 10, 10, 50, 50, b), InvalidInputError);
  EXPECT_THROW(render(img, Camera{}, {layer(c, kRed)}, {}, -1, 0, 20, 20, b), InvalidInputError);
  EXPECT_THROW(render(img, Camera{}, {layer(c, kRed)}, {}, 0, 0, 0, 20, b), InvalidInputError);

  TriMesh nan = c;
  nan.vertices[3].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(render(img, Camera{}, {layer(c, kRed), layer(nan, kRed)}, {}, 0, 0, 50, 50, b),
               InvalidInputError);
  TriMesh bad_index = c;
  bad_index.triangles[0][1] = 8;
  EXPECT_THROW(render(img, Camera{}, {layer(bad_index, kRed)}, {}, 0, 0, 50, 50, b),
               InvalidInputError);
  MeshLayer short_values = layer(c, kRed);
  short_values.vertex_values = {1, 2};
  EXPECT_THROW(render(img, Camera{}, {short_values}, {}, 0, 0, 50, 50, b), InvalidInputError);
  MeshLayer no_mesh;
  EXPECT_THROW(render(img, Camera{}, {no_mesh}, {}, 0, 0, 50, 50, b), InvalidInputError);
  EXPECT_THROW(render(img, Camera{}, {layer(c, kRed, 0.0)}, {}, 0, 0, 50, 50, b),
               InvalidInputError);
  const Marker lost{Vec3(0, std::numeric_limits<double>::infinity(), 0), "lost", kBlue};
  EXPECT_THROW(render(img, Camera{}, {layer(c, kRed)}, {lost}, 0, 0, 50, 50, b), InvalidInputError);
  const Camera parallel{Vec3(0, 0, -1), Vec3(0, 0, 2)};
  EXPECT_THROW(render(img, parallel, {layer(c, kRed)}, {}, 0, 0, 50, 50, b), InvalidInputError);
  EXPECT_THROW(render(img, Camera{}, {layer(c, kRed)}, {}, 0, 0, 50, 50, Aabb{}),
               InvalidInputError);
  for (const Rgb& p : img.pixels) ASSERT_EQ(p, kWhite);

  EXPECT_THROW(draw_colour_bar(img, 40, 0, 20, 20, Colormap::Greys, 0, 1, ""), InvalidInputError);
  EXPECT_THROW(draw_colour_bar(img, 0, 0, 10, 20, Colormap::Greys, 1, 1, ""), InvalidInputError);
  EXPECT_THROW(draw_text(img, 0, 0, "x", kBlack, 0), InvalidInputError);
  EXPECT_THROW(render_views({layer(c, kRed)}, {}, {}, 100, ""), InvalidInputError);

  Image broken = img;
  broken.pixels.pop_back();
  EXPECT_THROW(write_png(fs::temp_directory_path() / "socketsmith_never.png", broken),
               InvalidInputError);
  // A directory that cannot exist: its parent is a regular file.
  const fs::path file =
      fs::temp_directory_path() / ("socketsmith_raster_file_" + std::to_string(::getpid()));
  std::ofstream(file) << "x";
  EXPECT_THROW(write_png(file / "out.png", img), IoError);
  fs::remove(file);
}
