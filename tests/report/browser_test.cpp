// The HTML pages tested in a real browser (issue 23, item 4): a small design's report.html and
// compare's compare.html are opened in headless Chromium, which must load every picture
// (naturalWidth > 0), show every table with rows, log nothing on its console and paint a page that
// is not blank; printed with `--print-to-pdf`, each gives A4 pages (595 × 842 pt), none of them
// empty, and not more pages than the page has blocks that cannot be split.
//
// Chromium is Debian's `chromium` (scripts/setup.sh installs it). Without it the tests skip with a
// message, unless CI is set: in CI they fail.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

// The reader is only needed here, to read Chromium's screenshots.
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/rigid_alignment.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/shape_comparison.h"
#include "socketsmith/pipeline/sock_ply.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / ("browser_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The browser: $SOCKETSMITH_CHROMIUM, else chromium / chromium-browser / google-chrome on the PATH.
std::string find_chromium() {
  if (const char* e = std::getenv("SOCKETSMITH_CHROMIUM"); e && *e) return e;
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':'))
    for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
      const fs::path p = fs::path(dir) / name;
      if (fs::exists(p)) return p.string();
    }
  return {};
}

/// Skips the test (or fails it in CI) when there is no browser.
#define REQUIRE_CHROMIUM(var)                                                                              \
  const std::string var = find_chromium();                                                               \
  if (var.empty()) {                                                                                     \
    if (std::getenv("CI")) FAIL() << "chromium not found in CI: scripts/setup.sh installs it (apt-get install chromium)"; \
    GTEST_SKIP() << "chromium not found: install it (sudo apt-get install chromium, or scripts/setup.sh) to run "   \
                    "the browser tests";                                                                  \
  }

/// Runs headless Chromium on @p page with @p args (a fresh profile each time, so two tests can run at
/// once); stdout and stderr into files of @p dir. Returns the exit code.
int run_chromium(const std::string& chromium, const fs::path& dir, const std::string& tag, const std::string& args,
                 const fs::path& page) {
  const fs::path profile = dir / ("profile_" + tag);
  fs::remove_all(profile);
  const std::string cmd = "timeout 180 '" + chromium +
                          "' --headless --disable-gpu --no-sandbox --no-first-run --hide-scrollbars "
                          "--virtual-time-budget=10000 --enable-logging=stderr --v=0 --user-data-dir='" +
                          profile.string() + "' " + args + " 'file://" + fs::absolute(page).string() + "' > '" +
                          (dir / (tag + ".out")).string() + "' 2> '" + (dir / (tag + ".err")).string() + "'";
  const int rc = std::system(cmd.c_str());
  fs::remove_all(profile);
  return rc;
}

/// What the page's own probe found, and what Chromium logged on its console.
struct PageVerdict {
  bool found = false;          ///< the probe ran (the page loaded)
  int images = 0, broken = 0;  ///< <img> elements; those not loaded (naturalWidth or naturalHeight 0)
  int tables = 0, empty = 0;   ///< <table> elements; those without a single data cell
  int errors = 0;              ///< script errors and failed resources seen by the page
  int wide = 0;                ///< pictures wider than the window (cut off on screen)
  std::string detail;          ///< the probe's line
  std::vector<std::string> console;  ///< Chromium's CONSOLE lines (the reports run no script of their own)
};

// Installed before anything else in <head>: records script errors and resources that fail to load.
constexpr const char* kErrorTrap =
    "<script>window.__socketsmith_errors=[];window.addEventListener('error',function(e){var t=e.target;"
    "window.__socketsmith_errors.push(t&&t!==window?'resource '+(t.tagName||'')+' '+String(t.src||t.href||'').slice(0,60)"
    ":'script '+e.message);},true);</script>\n";
// Appended at the end of <body>: after load, one line into the DOM that --dump-dom prints.
constexpr const char* kProbe = R"(<script>
window.addEventListener('load', function () {
  var imgs = Array.from(document.images), broken = [], wide = [];
  imgs.forEach(function (im, i) {
    if (!im.complete || im.naturalWidth === 0 || im.naturalHeight === 0) broken.push(i + ':' + (im.alt || '').slice(0, 40));
    if (im.getBoundingClientRect().right > document.documentElement.clientWidth + 1) wide.push(i);
  });
  var tables = Array.from(document.querySelectorAll('table')), empty = [];
  tables.forEach(function (t, i) { if (t.querySelectorAll('td').length === 0) empty.push(i); });
  var errs = window.__socketsmith_errors || [];
  var pre = document.createElement('pre');
  pre.textContent = 'SOCKETSMITH-VERDICT images=' + imgs.length + ' broken=' + broken.length + ' tables=' + tables.length +
    ' empty=' + empty.length + ' errors=' + errs.length + ' wide=' + wide.length + ' | broken: ' + broken.join('; ') +
    ' | errors: ' + errs.join('; ') + ' |';
  document.body.appendChild(pre);
});
</script>
)";

/// @p page with the probe injected (a copy beside it, so relative links resolve alike), opened in
/// Chromium with --dump-dom.
PageVerdict probe_page(const std::string& chromium, const fs::path& page) {
  std::string html = read_file(page);
  const auto head = html.find("<head>");
  const auto body_end = html.rfind("</body>");
  EXPECT_NE(head, std::string::npos) << page << " has no <head>";
  EXPECT_NE(body_end, std::string::npos) << page << " has no </body>";
  PageVerdict v;
  if (head == std::string::npos || body_end == std::string::npos) return v;
  html = html.substr(0, head + 6) + kErrorTrap + html.substr(head + 6, body_end - head - 6) + kProbe +
         html.substr(body_end);
  const fs::path dir = page.parent_path();
  const fs::path probed = dir / (page.stem().string() + ".probed.html");
  std::ofstream(probed, std::ios::binary) << html;
  const int rc = run_chromium(chromium, dir, "dom", "--window-size=1280,2000 --dump-dom", probed);
  EXPECT_EQ(rc, 0) << "chromium --dump-dom failed; see " << (dir / "dom.err");
  const std::string dom = read_file(dir / "dom.out");
  const std::regex re(
      R"(SOCKETSMITH-VERDICT images=(\d+) broken=(\d+) tables=(\d+) empty=(\d+) errors=(\d+) wide=(\d+)([^<]*))");
  std::smatch m;
  if (std::regex_search(dom, m, re)) {
    v.found = true;
    v.images = std::stoi(m[1]);
    v.broken = std::stoi(m[2]);
    v.tables = std::stoi(m[3]);
    v.empty = std::stoi(m[4]);
    v.errors = std::stoi(m[5]);
    v.wide = std::stoi(m[6]);
    v.detail = m[0];
  }
  std::istringstream err(read_file(dir / "dom.err"));
  for (std::string line; std::getline(err, line);)
    if (line.find(":CONSOLE") != std::string::npos) v.console.push_back(line);
  fs::remove(probed);
  return v;
}

/// The page's screenshot: the share of pixels that are not background, and the grey level's SD.
struct ScreenshotStats {
  int width = 0, height = 0;
  double ink_fraction = 0;  ///< pixels differing from the most common colour by more than 24 levels
  double sd = 0;            ///< standard deviation of the grey level [0, 255]
};

ScreenshotStats screenshot(const std::string& chromium, const fs::path& page) {
  const fs::path dir = page.parent_path();
  const fs::path png = dir / (page.stem().string() + ".screenshot.png");
  fs::remove(png);
  const int rc = run_chromium(chromium, dir, "shot", "--window-size=1280,3000 --screenshot='" + png.string() + "'", page);
  EXPECT_EQ(rc, 0) << "chromium --screenshot failed; see " << (dir / "shot.err");
  ScreenshotStats s;
  int n = 0;
  unsigned char* px = stbi_load(png.string().c_str(), &s.width, &s.height, &n, 3);
  if (!px) return s;
  const size_t count = static_cast<size_t>(s.width) * s.height;
  std::vector<int> grey(count);
  double sum = 0, sum2 = 0;
  std::vector<int> hist(256, 0);
  for (size_t i = 0; i < count; ++i) {
    grey[i] = (px[3 * i] * 299 + px[3 * i + 1] * 587 + px[3 * i + 2] * 114) / 1000;
    ++hist[grey[i]];
    sum += grey[i];
    sum2 += static_cast<double>(grey[i]) * grey[i];
  }
  stbi_image_free(px);
  const int background = static_cast<int>(std::max_element(hist.begin(), hist.end()) - hist.begin());
  size_t ink = 0;
  for (int g : grey) ink += std::abs(g - background) > 24;
  s.ink_fraction = static_cast<double>(ink) / count;
  const double mean = sum / count;
  s.sd = std::sqrt(std::max(0.0, sum2 / count - mean * mean));
  return s;
}

/// One page of a PDF: its MediaBox and the length of its content stream.
struct PdfPage {
  double width_pt = 0, height_pt = 0;
  long content_bytes = -1;  ///< compressed length of its /Contents stream (-1: not found)
  bool has_font_or_image = false;
};

/// The pages of a PDF as Chromium (Skia) writes it: page dictionaries in plain text.
std::vector<PdfPage> pdf_pages(const std::string& pdf) {
  std::vector<PdfPage> pages;
  const std::regex page_re(R"(<<\s*/Type\s*/Page\b)");
  const std::regex box_re(R"(/MediaBox\s*\[\s*([-0-9.]+)\s+([-0-9.]+)\s+([-0-9.]+)\s+([-0-9.]+)\s*\])");
  const std::regex contents_re(R"(/Contents\s+(\d+)\s+0\s+R)");
  for (auto it = std::sregex_iterator(pdf.begin(), pdf.end(), page_re); it != std::sregex_iterator(); ++it) {
    const size_t start = static_cast<size_t>(it->position());
    const size_t end = pdf.find("endobj", start);
    const std::string dict = pdf.substr(start, end == std::string::npos ? 2000 : end - start);
    PdfPage p;
    std::smatch m;
    if (std::regex_search(dict, m, box_re)) {
      p.width_pt = std::stod(m[3]) - std::stod(m[1]);
      p.height_pt = std::stod(m[4]) - std::stod(m[2]);
    }
    p.has_font_or_image = dict.find("/Font") != std::string::npos || dict.find("/XObject") != std::string::npos;
    if (std::regex_search(dict, m, contents_re)) {
      std::string obj = "\n";  // appended, not "\n" + …: g++ 12 warns falsely (-Wrestrict) on that
      obj += m[1].str();
      obj += " 0 obj";
      const size_t o = pdf.find(obj);
      if (o != std::string::npos) {
        const std::string head = pdf.substr(o, 200);
        std::smatch lm;
        if (std::regex_search(head, lm, std::regex(R"(/Length\s+(\d+))"))) p.content_bytes = std::stol(lm[1]);
      }
    }
    pages.push_back(p);
  }
  return pages;
}

/// Prints @p page to PDF with Chromium and checks the pages: A4 (595 × 842 pt ± 2), none blank, at
/// most one page per block that may not be split (pictures, tables, headings) plus one. Returns the
/// page count.
int expect_a4_pdf(const std::string& chromium, const fs::path& page, int images, int tables) {
  const fs::path dir = page.parent_path();
  const fs::path pdf = dir / (page.stem().string() + ".pdf");
  fs::remove(pdf);
  const int rc = run_chromium(chromium, dir, "pdf", "--no-pdf-header-footer --print-to-pdf='" + pdf.string() + "'", page);
  EXPECT_EQ(rc, 0) << "chromium --print-to-pdf failed; see " << (dir / "pdf.err");
  const std::string bytes = read_file(pdf);
  EXPECT_EQ(bytes.rfind("%PDF-", 0), 0u) << pdf << " is not a PDF";
  const auto pages = pdf_pages(bytes);
  EXPECT_GE(pages.size(), 1u) << "no page in " << pdf;
  for (size_t i = 0; i < pages.size(); ++i) {
    EXPECT_NEAR(pages[i].width_pt, 595.28, 2.0) << "page " << i + 1 << " of " << pdf << " is not A4 wide";
    EXPECT_NEAR(pages[i].height_pt, 841.89, 2.0) << "page " << i + 1 << " of " << pdf << " is not A4 high";
    EXPECT_GT(pages[i].content_bytes, 100) << "page " << i + 1 << " of " << pdf << " is blank";
    EXPECT_TRUE(pages[i].has_font_or_image) << "page " << i + 1 << " of " << pdf << " has neither text nor picture";
  }
  // A block that may not be split starts at most one new page: more pages than blocks means pages
  // pushed out empty or a block larger than a page sliced across many.
  EXPECT_LE(static_cast<int>(pages.size()), images + tables + 1) << pdf;
  return static_cast<int>(pages.size());
}

/// The screen checks of a page: it loaded, every picture shown, every table with rows, no error.
void expect_renders(const std::string& chromium, const fs::path& page, int min_images, int min_tables,
                    PageVerdict* out = nullptr) {
  const PageVerdict v = probe_page(chromium, page);
  ASSERT_TRUE(v.found) << "the probe did not run in " << page << " (see " << page.parent_path() / "dom.err" << ")";
  EXPECT_GE(v.images, min_images) << v.detail;
  EXPECT_EQ(v.broken, 0) << "pictures that did not load: " << v.detail;
  EXPECT_GE(v.tables, min_tables) << v.detail;
  EXPECT_EQ(v.empty, 0) << "tables without rows: " << v.detail;
  EXPECT_EQ(v.errors, 0) << "errors on the page: " << v.detail;
  EXPECT_EQ(v.wide, 0) << "pictures wider than the window: " << v.detail;
  for (const auto& line : v.console) ADD_FAILURE() << "console: " << line;
  const ScreenshotStats s = screenshot(chromium, page);
  EXPECT_EQ(s.width, 1280) << "no screenshot of " << page;
  // A page of text, tables and pictures: measured 10–25 % ink and a grey SD of 50–70 on the
  // design report; a blank (or background-only) page has neither.
  EXPECT_GT(s.ink_fraction, 0.02) << page << ": the screenshot is (nearly) blank";
  EXPECT_GT(s.sd, 10.0) << page << ": the screenshot is (nearly) uniform";
  if (out) *out = v;
}

/// A small design of the embedded sample (the smallest stump its socket is built on reliably).
fs::path small_design(const std::string& name) {
  const fs::path dir = fresh_dir(name);
  design::CaseFile c = pipeline::demo_case(1800);
  c.closed_loop_donnings = 1;  // the default report's "Delivered pressures" section, one donning
  const nlohmann::json j = pipeline::run_design(c, dir, true);
  EXPECT_TRUE(j.value("constraints_met", false)) << "the 1.8k demo's design should meet its constraints";
  return dir / "report.html";
}

/// compare's page: a generated limb against itself moved by a rigid motion.
fs::path small_compare(const std::string& name) {
  const fs::path dir = fresh_dir(name);
  const auto limb = volume::generate_limb(volume::default_params(geometry::LimbType::Transtibial, 3)).skin;
  geometry::RigidTransform motion =
      geometry::rotation_about(geometry::Vec3(0.01, -0.02, 0.05), geometry::Vec3(0.3, 1.0, 0.2), 10 * M_PI / 180);
  motion.translation += geometry::Vec3(0.004, -0.003, 0.006);
  geometry::write_mesh(dir / "a.stl", limb);
  geometry::write_mesh(dir / "b.stl", geometry::transformed(limb, motion));
  pipeline::run_compare(dir / "a.stl", dir / "b.stl", dir / "out");
  return dir / "out" / "compare.html";
}

TEST(Browser, design_report_renders_in_chromium) {
  REQUIRE_CHROMIUM(chromium);
  const fs::path page = small_design("design_screen");
  // Radar, 3 maps, 3 profiles, thickness, rectification map, slices plot at least; the patient,
  // inputs, constraints, comfort, socket, rectification and slice tables.
  expect_renders(chromium, page, 8, 7);
}

TEST(Browser, design_report_prints_to_a4_pdf) {
  REQUIRE_CHROMIUM(chromium);
  const fs::path page = small_design("design_print");
  const PageVerdict v = probe_page(chromium, page);
  ASSERT_TRUE(v.found);
  const int pages = expect_a4_pdf(chromium, page, v.images, v.tables);
  EXPECT_GE(pages, 3) << "a design report with " << v.images << " pictures fits on fewer than 3 A4 pages?";
}

TEST(Browser, sock_ply_report_renders_and_prints_to_a4_pdf) {
  REQUIRE_CHROMIUM(chromium);
  const fs::path dir = fresh_dir("sock_ply");
  pipeline::DesignArtifacts art;
  design::CaseFile c = pipeline::demo_case(1800);
  c.closed_loop = false;  // the sock-ply study's own donnings are this page's
  pipeline::run_design(c, dir, true, {}, &art);
  ASSERT_TRUE(art.result.socket.has_value());
  pipeline::SockPlyOptions o;
  o.volume_changes = {-0.04, 0.04};
  art.result.sock_ply = pipeline::run_sock_ply_study(*art.setup, art.result, o);
  pipeline::write_design_outputs(*art.setup, art.result, dir, 0.0);
  ASSERT_NE(read_file(dir / "report.html").find("Sock-ply sensitivity"), std::string::npos);
  PageVerdict v;
  // The design's pictures and tables, and the study's: three maps, the plots, the table.
  expect_renders(chromium, dir / "report.html", 14, 8, &v);
  expect_a4_pdf(chromium, dir / "report.html", v.images, v.tables);
}

TEST(Browser, compare_page_renders_in_chromium) {
  REQUIRE_CHROMIUM(chromium);
  const fs::path page = small_compare("compare_screen");
  expect_renders(chromium, page, 2, 2);
}

TEST(Browser, compare_page_prints_to_a4_pdf) {
  REQUIRE_CHROMIUM(chromium);
  const fs::path page = small_compare("compare_print");
  const PageVerdict v = probe_page(chromium, page);
  ASSERT_TRUE(v.found);
  EXPECT_GE(expect_a4_pdf(chromium, page, v.images, v.tables), 1);
}

}  // namespace
}  // namespace socketsmith
