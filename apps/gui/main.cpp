// socketsmith-gui: the interactive socket design application (docs/gui.md).
// Interactive: socketsmith-gui [--case FILE | --limb FILE | --demo] [--target-nodes N]
// Headless (tests, screenshots, benchmark), under Xvfb:
//   socketsmith-gui --headless --case FILE|--limb FILE|--demo [--target-nodes N] [--script actions.json]
//                   [--frames N] [--screenshot-dir DIR] [--bench-drag SECONDS [--bench-spot NAME]]
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>

#include <CLI/CLI.hpp>
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include "app.h"
#include "fonts.h"
#include "common/parse_command_line.h"
#include "headless.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/exit_status.h"
#include "socketsmith/design/input_limits.h"
#include "socketsmith/core/log.h"

namespace {

struct Flags {
  std::string case_file;
  std::string limb_file;
  bool demo = false;
  int target_nodes = 8000;
  bool headless = false;
  std::string script;
  int frames = 3;
  std::string screenshot_dir;
  double bench_drag_s = 0;
  std::string bench_spot;
  std::string bench_json;
  int width = 1600, height = 1000;
};

void glfw_error(int code, const char* text) { std::fprintf(stderr, "socketsmith-gui: GLFW error %d: %s\n", code, text); }

int run(const Flags& f) {
  using namespace socketsmith;
  glfwSetErrorCallback(glfw_error);
  if (!glfwInit()) {
    std::fprintf(stderr, "socketsmith-gui: cannot open a display (no X server? run under xvfb-run for --headless)\n");
    return 2;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  GLFWwindow* window = glfwCreateWindow(f.width, f.height, "socketsmith", nullptr, nullptr);
  if (!window) {
    glfwTerminate();
    std::fprintf(stderr, "socketsmith-gui: cannot create an OpenGL 3.3 core window\n");
    return 2;
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(f.headless ? 0 : 1);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // the layout is fixed; no imgui.ini beside the user's files
  ImGui::StyleColorsDark();
  if (const std::string font = gui::window_font_file(); !gui::load_window_font(font))
    std::fprintf(stderr,
                 "socketsmith-gui: no font at '%s' (apt-get install fonts-dejavu-core, or set SOCKETSMITH_GUI_FONT to a "
                 ".ttf); the built-in font draws Greek letters as '?'\n",
                 font.c_str());
  ImGui_ImplGlfw_InitForOpenGL(window, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  int status = 0;
  {
    gui::App app(window, f.headless);
    if (!f.case_file.empty()) app.session().open_case(f.case_file);
    else if (!f.limb_file.empty()) app.session().open_limb(f.limb_file, f.target_nodes);
    else if (f.demo) app.session().open_demo(f.target_nodes);
    std::unique_ptr<gui::HeadlessRunner> runner;
    if (f.headless) {
      gui::HeadlessOptions ho;
      ho.screenshot_dir = f.screenshot_dir;
      ho.frames = f.frames;
      ho.bench_drag_seconds = f.bench_drag_s;
      ho.bench_spot = f.bench_spot;
      ho.bench_json = f.bench_json;
      std::vector<nlohmann::json> actions;
      if (!f.script.empty()) actions = gui::read_script(f.script);
      runner = std::make_unique<gui::HeadlessRunner>(app, std::move(actions), ho);
    }
    for (;;) {
      if (glfwWindowShouldClose(window)) {
        if (app.request_close()) break;
        glfwSetWindowShouldClose(window, 0);
      }
      // Interactive: wakes for input at once; otherwise at 60 Hz while something is computed or
      // edited, 4 Hz when all is still (software OpenGL would spend a core redrawing an idle window).
      if (f.headless) glfwPollEvents();
      else glfwWaitEventsTimeout(app.is_idle() && !ImGui::IsAnyItemActive() ? 0.25 : 1.0 / 60.0);
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      int w = 0, h = 0;
      glfwGetFramebufferSize(window, &w, &h);
      app.frame(w, h);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      if (runner && runner->after_frame(w, h)) break;
      glfwSwapBuffers(window);
    }
    if (runner) status = runner->exit_status();
  }
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  glfwTerminate();
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  Flags f;
  CLI::App cli("socketsmith-gui: interactive prosthetic socket design");
  auto* case_opt = cli.add_option("--case", f.case_file, "case file to open (JSON, docs/case_file.md)");
  auto* limb_opt = cli.add_option("--limb", f.limb_file, "limb scan to open as a new case (STL/OBJ/PLY/AOP)")->excludes(case_opt);
  cli.add_flag("--demo", f.demo, "open the demo sample (generated transtibial limb)")->excludes(case_opt)->excludes(limb_opt);
  cli.add_option("--target-nodes", f.target_nodes, "stump size of the demo or the limb (default 8000)")
      ->check(CLI::Validator(
          [](std::string& text) {  // the case file's range (design/input_limits.h)
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (text.empty() || end != text.c_str() + text.size()) return "'" + text + "' is not a whole number";
            return socketsmith::design::input_violation(socketsmith::design::limits::kTargetNodes, v);
          },
          socketsmith::design::describe(socketsmith::design::limits::kTargetNodes)));
  cli.add_flag("--headless", f.headless, "run a script, save screenshots and exit (tests, docs; under xvfb-run)");
  cli.add_option("--script", f.script, "headless: actions to apply (JSON, docs/gui.md)");
  cli.add_option("--frames", f.frames, "headless: frames rendered after the last action")->check(CLI::Range(0, 100000));
  cli.add_option("--screenshot-dir", f.screenshot_dir, "headless: folder for the PNG screenshots");
  cli.add_option("--bench-drag", f.bench_drag_s, "headless: drag a spot's amplitude for this many seconds, print frames/s and solves/s")
      ->check(CLI::Range(0.0, 600.0));
  cli.add_option("--bench-spot", f.bench_spot, "headless: the spot dragged by --bench-drag (default: the first)");
  cli.add_option("--bench-json", f.bench_json, "headless: also write the --bench-drag result to this JSON file");
  cli.add_option("--width", f.width, "window width [px]")->check(CLI::Range(800, 8000));
  cli.add_option("--height", f.height, "window height [px]")->check(CLI::Range(600, 8000));
  if (const std::optional<int> code = socketsmith::apps::parse_command_line(cli, argc, argv, "socketsmith-gui")) {
    return *code;
  }
  if (f.headless && f.case_file.empty() && f.limb_file.empty() && !f.demo) {
    std::fprintf(stderr, "socketsmith-gui: --headless needs --case FILE, --limb FILE or --demo\n");
    return 2;
  }
  try {
    return run(f);
  } catch (...) {
    // Whatever escaped the window (the window itself shows and keeps errors of the design).
    const auto status = socketsmith::exit_status(std::current_exception());
    std::fprintf(stderr, "socketsmith-gui: %s\n", status.line().c_str());
    return status.code == socketsmith::kExitInternal ? status.code : 1;
  }
}
