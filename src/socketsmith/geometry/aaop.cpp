#include "socketsmith/geometry/aaop.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <numbers>
#include <system_error>

#include <fmt/format.h>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/geometry/surface_query.h"

namespace socketsmith::geometry {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\f' || c == '\v'; }

std::string_view trimmed(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

std::string shown(std::string_view tok) {
  if (tok.size() > 40) return std::string(tok.substr(0, 40)) + "...";
  return std::string(tok);
}

/// The lines of @p text, split at CR, LF or CRLF.
std::vector<std::string_view> split_lines(std::string_view text) {
  std::vector<std::string_view> lines;
  std::size_t start = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\r' && text[i] != '\n') continue;
    lines.push_back(text.substr(start, i - start));
    if (text[i] == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
    start = i + 1;
  }
  if (start < text.size()) lines.push_back(text.substr(start));
  return lines;
}

/// Reads the lines of one file in order, naming the file and the line in every error.
class LineReader {
 public:
  LineReader(std::string_view text, const std::string& name) : lines_(split_lines(text)), name_(name) {}

  int line_number() const { return static_cast<int>(next_); }  // 1-based number of the last line read
  bool at_end() const { return next_ >= lines_.size(); }

  std::string_view line(const std::string& what) {
    if (at_end())
      fail("read_aaop: '{}' ends after line {} where {} was expected (the file is truncated or a "
           "count is too large)",
           name_, lines_.size(), what);
    return lines_[next_++];
  }

  double number(const std::string& what) {
    const std::string_view raw = trimmed(line(what));
    // The first token: radius lines may carry a second value.
    const std::string_view tok = raw.substr(0, std::min(raw.size(), raw.find_first_of(" \t")));
    double v = 0.0;
    const char* b = tok.data();
    const char* e = b + tok.size();
    if (b < e && *b == '+') ++b;
    auto [ptr, ec] = std::from_chars(b, e, v);
    if (ec == std::errc::result_out_of_range && ptr == e) v = HUGE_VAL;  // reported as not finite
    else if (tok.empty() || ec != std::errc() || ptr != e)
      fail("read_aaop: '{}' line {}: '{}' is not a number (expected {})", name_, line_number(),
           shown(raw), what);
    if (!std::isfinite(v))
      fail("read_aaop: '{}' line {}: {} is '{}' (expected a finite number)", name_, line_number(), what,
           shown(tok));
    return v;
  }

  int count(const std::string& what, int min_value) {
    const std::string_view tok = trimmed(line(what));
    int v = 0;
    auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (tok.empty() || ec != std::errc() || ptr != tok.data() + tok.size() || v < min_value)
      fail("read_aaop: '{}' line {}: {} is '{}' (expected a whole number >= {})", name_, line_number(),
           what, shown(tok), min_value);
    constexpr int kMaxCount = 1 << 20;
    if (v > kMaxCount)
      fail("read_aaop: '{}' line {}: {} is {} (more than {}; the count is wrong)", name_, line_number(),
           what, v, kMaxCount);
    return v;
  }

  std::size_t remaining_non_blank() const {
    return static_cast<std::size_t>(std::count_if(lines_.begin() + static_cast<std::ptrdiff_t>(next_),
                                                  lines_.end(),
                                                  [](std::string_view l) { return !trimmed(l).empty(); }));
  }

 private:
  std::vector<std::string_view> lines_;
  std::size_t next_ = 0;
  const std::string& name_;
};

/// Angle difference wrapped to (-180, 180] degrees.
double wrapped_deg(double d) {
  d = std::fmod(d, 360.0);
  if (d > 180.0) d -= 360.0;
  if (d <= -180.0) d += 360.0;
  return d;
}

std::string fmt_number(double v) { return fmt::format("{}", v); }


/// The version line, the comments up to 'END COMMENTS', the coordinate system and the side.
void read_aaop_header(LineReader& in, const std::string& name, AaopShape& s) {
  s.version = std::string(trimmed(in.line("the version line")));
  if (s.version.rfind("AAOP", 0) != 0)
    fail("read_aaop: '{}' line 1: '{}' is not an AAOP version line (expected 'AAOP1')", name,
         shown(s.version));
  for (;;) {
    const std::string_view l = trimmed(in.line("'END COMMENTS'"));
    if (l == "END COMMENTS") break;
    s.comments.emplace_back(l);
  }
  const std::string_view cys = trimmed(in.line("the coordinate system"));
  if (cys != "CYLINDRICAL")
    fail("read_aaop: '{}' line {}: coordinate system '{}' is not supported (expected CYLINDRICAL)", name,
         in.line_number(), shown(cys));
  s.side = std::string(trimmed(in.line("the side")));
}

/// The landmark count, then each landmark's name and its points (radius [mm], angle [deg],
/// height [mm]).
void read_aaop_landmarks(LineReader& in, const std::string& name, AaopShape& s) {
  const int n_land = in.count("the landmark count", 0);
  for (int i = 0; i < n_land; ++i) {
    AaopLandmark lm;
    lm.name = std::string(trimmed(in.line(fmt::format("the name of landmark {}", i + 1))));
    if (lm.name.empty())
      fail("read_aaop: '{}' line {}: landmark {} has an empty name", name, in.line_number(), i + 1);
    const int n_points = in.count(fmt::format("the point count of landmark {}", lm.name), 1);
    for (int k = 0; k < n_points; ++k) {
      const std::string what = fmt::format("landmark {} point {}", lm.name, k + 1);
      const double r = in.number(what + " radius [mm]");
      const double t = in.number(what + " angle [deg]");
      const double z = in.number(what + " height [mm]");
      lm.points_mm.emplace_back(r, t, z);
    }
    s.landmarks.push_back(std::move(lm));
  }
}

/// Listed spoke angles must go around once, in one direction.
void check_spokes_go_around(const std::vector<double>& angles_deg, const std::string& name) {
  const int n_spokes = static_cast<int>(angles_deg.size());
  const double dir = wrapped_deg(angles_deg[1] - angles_deg[0]);
  double turn = 0.0;
  for (int j = 0; j < n_spokes; ++j) {
    const double d = wrapped_deg(angles_deg[(j + 1) % n_spokes] - angles_deg[j]);
    if (d == 0.0 || (d > 0) != (dir > 0))
      fail("read_aaop: '{}': spoke angles {} and {} ({} and {} deg) do not go around in one direction",
           name, j + 1, (j + 1) % n_spokes + 1, angles_deg[j], angles_deg[(j + 1) % n_spokes]);
    turn += d;
  }
  if (std::abs(std::abs(turn) - 360.0) > 1e-6)
    fail("read_aaop: '{}': the {} spoke angles go {} deg around, not one full turn", name, n_spokes,
         std::abs(turn));
}

/// The spoke count and spacing [deg]: spokes from -90 deg at that spacing, or (spacing 0) listed
/// angles. Returns the spoke count.
int read_aaop_spokes(LineReader& in, const std::string& name, AaopShape& s) {
  const int n_spokes = in.count("the spoke count", 3);
  const int spoke_line = in.line_number();
  s.spoke_spacing_deg = in.number("the spoke spacing [deg]");
  if (s.spoke_spacing_deg < 0.0)
    fail("read_aaop: '{}' line {}: spoke spacing {} deg is negative", name, in.line_number(),
         s.spoke_spacing_deg);
  if (s.spoke_spacing_deg > 0.0) {
    if (std::abs(n_spokes * s.spoke_spacing_deg - 360.0) > 1e-3)
      fail("read_aaop: '{}' line {}: {} spokes {} deg apart make {} deg, not a full turn (the count "
           "or the spacing is wrong)",
           name, spoke_line, n_spokes, s.spoke_spacing_deg, n_spokes * s.spoke_spacing_deg);
    for (int j = 0; j < n_spokes; ++j) s.spoke_angles_deg.push_back(-90.0 + j * s.spoke_spacing_deg);
  } else {
    for (int j = 0; j < n_spokes; ++j)
      s.spoke_angles_deg.push_back(in.number(fmt::format("spoke angle {} [deg]", j + 1)));
    check_spokes_go_around(s.spoke_angles_deg, name);
  }
  return n_spokes;
}

/// The slice count and spacing [mm]: slices from 0 at that spacing, or (spacing 0) listed
/// increasing heights. Returns the slice count.
int read_aaop_slices(LineReader& in, const std::string& name, AaopShape& s) {
  const int n_slices = in.count("the slice count", 2);
  s.slice_spacing_mm = in.number("the slice spacing [mm]");
  if (s.slice_spacing_mm < 0.0)
    fail("read_aaop: '{}' line {}: slice spacing {} mm is negative", name, in.line_number(),
         s.slice_spacing_mm);
  if (s.slice_spacing_mm > 0.0) {
    for (int i = 0; i < n_slices; ++i) s.slice_heights_mm.push_back(i * s.slice_spacing_mm);
  } else {
    for (int i = 0; i < n_slices; ++i) {
      s.slice_heights_mm.push_back(in.number(fmt::format("slice height {} [mm]", i + 1)));
      if (i > 0 && !(s.slice_heights_mm[i] > s.slice_heights_mm[i - 1]))
        fail("read_aaop: '{}' line {}: slice height {} mm does not increase from the previous {} mm",
             name, in.line_number(), s.slice_heights_mm[i], s.slice_heights_mm[i - 1]);
    }
  }
  return n_slices;
}

}  // namespace

AaopShape parse_aaop(std::string_view text, const std::string& name) {
  if (std::all_of(text.begin(), text.end(), [](char c) { return is_blank(c) || c == '\r' || c == '\n'; }))
    fail("read_aaop: '{}' is empty; expected an AAOP shape file", name);
  LineReader in(text, name);
  AaopShape s;
  read_aaop_header(in, name, s);
  read_aaop_landmarks(in, name, s);
  const int n_spokes = read_aaop_spokes(in, name, s);
  const int n_slices = read_aaop_slices(in, name, s);
  s.radii_mm.reserve(static_cast<std::size_t>(n_slices) * static_cast<std::size_t>(n_spokes));
  for (int i = 0; i < n_slices; ++i)
    for (int j = 0; j < n_spokes; ++j) {
      const double r = in.number(fmt::format("the radius of slice {} spoke {} [mm]", i + 1, j + 1));
      if (r < 0.0)
        fail("read_aaop: '{}' line {}: the radius of slice {} spoke {} is {} mm (expected >= 0)", name,
             in.line_number(), i + 1, j + 1, r);
      s.radii_mm.push_back(r);
    }
  if (const std::size_t extra = in.remaining_non_blank(); extra > 0)
    fail("read_aaop: '{}' has {} more line(s) after its {} × {} radii (a spoke or slice count is wrong)",
         name, extra, n_slices, n_spokes);
  return s;
}

AaopShape read_aaop(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    fail<IoError>("read_aaop: cannot open '{}': it is a directory (expected an AAOP file)", path.string());
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail<IoError>("read_aaop: cannot open '{}' (check the path and permissions)", path.string());
  std::string data;
  char buf[1 << 16];
  std::size_t k;
  while ((k = std::fread(buf, 1, sizeof buf, f)) > 0) data.append(buf, k);
  const bool bad = std::ferror(f) != 0;
  std::fclose(f);
  if (bad) fail<IoError>("read_aaop: cannot read '{}'", path.string());
  return parse_aaop(data, path.string());
}

std::string format_aaop(const AaopShape& s) {
  require(!s.spoke_angles_deg.empty() && s.num_slices() >= 2 &&
              s.radii_mm.size() == static_cast<std::size_t>(s.num_slices()) * s.spoke_angles_deg.size(),
          "write_aaop: {} radii for {} slices × {} spokes", s.radii_mm.size(), s.num_slices(), s.num_spokes());
  fmt::memory_buffer b;
  auto out = std::back_inserter(b);
  fmt::format_to(out, "{}\n", s.version.empty() ? "AAOP1" : s.version);
  for (const std::string& c : s.comments) fmt::format_to(out, "{}\n", c);
  fmt::format_to(out, "END COMMENTS\nCYLINDRICAL\n{}\n{}\n", s.side.empty() ? "NONE" : s.side, s.landmarks.size());
  for (const AaopLandmark& lm : s.landmarks) {
    fmt::format_to(out, "{}\n{}\n", lm.name, lm.points_mm.size());
    for (const Vec3& p : lm.points_mm)
      fmt::format_to(out, "{}\n{}\n{}\n", fmt_number(p.x()), fmt_number(p.y()), fmt_number(p.z()));
  }
  fmt::format_to(out, "{}\n{}\n", s.num_spokes(), fmt_number(s.spoke_spacing_deg));
  if (s.spoke_spacing_deg == 0.0)
    for (double a : s.spoke_angles_deg) fmt::format_to(out, "{}\n", fmt_number(a));
  fmt::format_to(out, "{}\n{}\n", s.num_slices(), fmt_number(s.slice_spacing_mm));
  if (s.slice_spacing_mm == 0.0)
    for (double h : s.slice_heights_mm) fmt::format_to(out, "{}\n", fmt_number(h));
  for (double r : s.radii_mm) {
    require(std::isfinite(r) && r >= 0.0, "write_aaop: radius {} mm is not a finite length >= 0", r);
    fmt::format_to(out, "{}\n", fmt_number(r));
  }
  return fmt::to_string(b);
}

void write_aaop(const std::filesystem::path& path, const AaopShape& shape) {
  write_text_atomically(path, format_aaop(shape));
}

Vec3 aaop_point_m(const Vec3& rtz) {
  const double t = rtz.y() * kDeg;
  return units::mm * Vec3(rtz.x() * std::cos(t), rtz.x() * std::sin(t), rtz.z());
}

TriMesh aaop_surface(const AaopShape& s, bool* distal_closed, bool* proximal_closed) {
  const int ns = s.num_spokes();
  const int nl = s.num_slices();
  require(ns >= 3 && nl >= 2 && s.radii_mm.size() == static_cast<std::size_t>(ns) * nl,
          "aaop_surface: {} radii for {} slices × {} spokes", s.radii_mm.size(), nl, ns);
  auto all_zero = [&](int i) {
    for (int j = 0; j < ns; ++j)
      if (s.radius_mm(i, j) != 0.0) return false;
    return true;
  };
  const bool close_first = all_zero(0);
  const bool close_last = all_zero(nl - 1);
  if (distal_closed) *distal_closed = close_first;
  if (proximal_closed) *proximal_closed = close_last;

  TriMesh mesh;
  std::vector<int> first(nl);  // index of the slice's first vertex
  for (int i = 0; i < nl; ++i) {
    first[i] = mesh.num_vertices();
    const double z = s.slice_heights_mm[i];
    if ((i == 0 && close_first) || (i == nl - 1 && close_last)) {
      mesh.vertices.push_back(units::mm * Vec3(0.0, 0.0, z));
      continue;
    }
    for (int j = 0; j < ns; ++j)
      mesh.vertices.push_back(aaop_point_m(Vec3(s.radius_mm(i, j), s.spoke_angles_deg[j], z)));
  }
  auto v = [&](int i, int j) {
    const bool collapsed = (i == 0 && close_first) || (i == nl - 1 && close_last);
    return collapsed ? first[i] : first[i] + j;
  };
  // Outward normals: (a point, its counter-clockwise neighbour, the point above) is counter-clockwise
  // seen from outside.
  const bool ccw = wrapped_deg(s.spoke_angles_deg[1] - s.spoke_angles_deg[0]) > 0.0;
  for (int i = 0; i + 1 < nl; ++i)
    for (int j = 0; j < ns; ++j) {
      const int k = (j + 1) % ns;
      const int a = ccw ? j : k;  // the clockwise one of the pair
      const int c = ccw ? k : j;  // its counter-clockwise neighbour
      const std::array<int, 3> t1{v(i, a), v(i, c), v(i + 1, a)};
      const std::array<int, 3> t2{v(i, c), v(i + 1, c), v(i + 1, a)};
      for (const auto& t : {t1, t2})
        if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) mesh.triangles.push_back(t);
    }
  return mesh;
}

AaopShape sample_aaop(const TriMesh& mesh, const LimbFrame& frame, const AaopSampleOptions& o) {
  require(o.spokes >= 3 && o.spokes <= 3600, "sample_aaop: {} spokes (expected 3 to 3600)", o.spokes);
  const int rings = o.heights_mm.empty() ? o.slices - (o.close_distal ? 1 : 0)
                                         : static_cast<int>(o.heights_mm.size());
  const int min_rings = o.heights_mm.empty() ? 2 : (o.close_distal ? 1 : 2);
  require(rings >= min_rings && rings <= 100000, "sample_aaop: {} ring slices (expected {} to 100000)",
          rings, min_rings);
  for (std::size_t i = 0; i < o.heights_mm.size(); ++i)
    require(std::isfinite(o.heights_mm[i]) && (i == 0 ? !o.close_distal || o.heights_mm[i] > 0.0
                                                      : o.heights_mm[i] > o.heights_mm[i - 1]),
            "sample_aaop: slice height {} mm (expected increasing heights{})", o.heights_mm[i],
            o.close_distal ? " above 0" : "");
  require(std::isfinite(o.end_margin) && o.end_margin > 0.0 && o.end_margin < 0.25,
          "sample_aaop: end margin {} (expected a fraction in (0, 0.25))", o.end_margin);
  require(!mesh.empty(), "sample_aaop: the mesh has no triangles");
  const Vec3 x_axis = frame.anterior.normalized();
  const Vec3 z_axis = frame.axis.normalized();
  const Vec3 y_axis = z_axis.cross(x_axis);

  double h_min = std::numeric_limits<double>::infinity();
  double h_max = -h_min;
  for (const Vec3& p : mesh.vertices) {
    const double h = (p - frame.origin).dot(z_axis);
    h_min = std::min(h_min, h);
    h_max = std::max(h_max, h);
  }
  const double length = h_max - h_min;
  require(std::isfinite(length) && length > 0.0, "sample_aaop: the mesh has no extent along the axis");

  AaopShape s;
  s.side = o.side;
  s.comments = o.comments;
  s.spoke_spacing_deg = 360.0 / o.spokes;
  for (int j = 0; j < o.spokes; ++j) s.spoke_angles_deg.push_back(-90.0 + j * s.spoke_spacing_deg);
  s.slice_spacing_mm = 0.0;
  if (o.close_distal) {
    s.slice_heights_mm.push_back(0.0);
    s.radii_mm.assign(static_cast<std::size_t>(o.spokes), 0.0);
  }
  const double h_lo = h_min + o.end_margin * length;
  const double h_hi = h_max - o.end_margin * length;
  for (int i = 0; i < rings; ++i) {
    const double h = !o.heights_mm.empty() ? h_min + o.heights_mm[i] * units::mm
                                           : h_lo + (h_hi - h_lo) * i / (rings - 1);
    s.slice_heights_mm.push_back((h - h_min) / units::mm);
    const Vec3 c = frame.origin + h * z_axis;
    const Slice sl = slice_surface(mesh, c, z_axis);
    std::vector<std::array<double, 4>> segs;  // (x0, y0, x1, y1) relative to the axis
    segs.reserve(sl.segments.size());
    for (const auto& seg : sl.segments)
      segs.push_back({(seg[0] - c).dot(x_axis), (seg[0] - c).dot(y_axis), (seg[1] - c).dot(x_axis),
                      (seg[1] - c).dot(y_axis)});
    for (int j = 0; j < o.spokes; ++j) {
      const double t = s.spoke_angles_deg[j] * kDeg;
      const double dx = std::cos(t), dy = std::sin(t);
      double best = -1.0;
      for (const auto& q : segs) {
        const double ex = q[2] - q[0], ey = q[3] - q[1];
        const double den = dx * ey - dy * ex;
        if (den == 0.0) continue;
        const double r = (q[0] * ey - q[1] * ex) / den;
        const double u = (q[0] * dy - q[1] * dx) / den;
        if (u >= 0.0 && u <= 1.0 && r >= 0.0) best = std::max(best, r);
      }
      if (best < 0.0)
        fail("sample_aaop: the spoke at {:.1f} deg misses the surface {:.1f} mm above its distal end (the "
             "shape is not a tube around the axis there; give the limb's axis)",
             s.spoke_angles_deg[j], (h - h_min) / units::mm);
      s.radii_mm.push_back(best / units::mm);
    }
  }
  return s;
}

AaopShape sample_aaop(const TriMesh& mesh, const AaopSampleOptions& options) {
  return sample_aaop(mesh, estimate_limb_axis(mesh), options);
}

}  // namespace socketsmith::geometry
