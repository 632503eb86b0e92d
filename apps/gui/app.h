#pragma once
/// @file app.h
/// socketsmith-gui's application: draws a pipeline::DesignSession (the open case, its edits,
/// undo/redo, autosave, solves and results — all in the library) and turns the window's input into
/// the session's calls. One frame() per displayed frame; everything slow runs off the UI thread in
/// the session, and every error is shown in the window with the user's work kept.

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "viewport.h"
#include "socketsmith/pipeline/design_session.h"

struct GLFWwindow;

namespace socketsmith::gui {

/// The field the stump is coloured by. Deviation: the signed distance from the stump's skin to a
/// second shape (compare_with), > 0 where that shape lies outside. Rectification: socket minus
/// limb (pipeline::compute_rectification), < 0 where the socket indents the tissue. Delivered:
/// the pressure the corrected socket delivers donned and stood on (pipeline::DeliveryCheck);
/// DeliveryError: that minus the designed pressure.
enum class Field { Pressure, Threshold, Ratio, Displacement, Deviation, Rectification, Delivered, DeliveryError };
const char* to_string(Field field);
/// "pressure" | "threshold" | "ratio" | "displacement" | "deviation" | "rectification" | "delivered" |
/// "delivery_error";
/// @throws InvalidInputError otherwise.
Field parse_field(const std::string& text);

using pipeline::RectificationChart;
using pipeline::RectificationRow;

class App {
 public:
  App(GLFWwindow* window, bool is_headless);
  ~App();
  App(const App&) = delete;
  App& operator=(const App&) = delete;

  /// The open case: its document, edits, undo/redo, solves and results (docs/gui.md, "Headless
  /// mode", lists the edits a script makes through it).
  pipeline::DesignSession& session() { return session_; }
  const pipeline::DesignSession& session() const { return session_; }

  // ---- What the window adds to the session's edits ----------------------------------------------
  /// One edit as a script action (pipeline::DesignSession::apply); an added spot is selected, a
  /// removed one unselected, as with the mouse.
  void apply(const nlohmann::json& action);
  /// Adds a spot at the skin point nearest @p point (world [m]) and selects it.
  void add_spot_at(const Vec3& point, design::SpotType type, double amplitude_pa);
  void remove_spot(int index);
  /// Colours the stump by @p field; Rectification also asks the session for its chart, Delivered and
  /// DeliveryError for the delivery check, each kept up to date after every design from then on.
  void set_field(Field field);
  void set_view_toggles(bool bones, bool landmarks, bool socket, float stump_opacity) {
    stump_alpha_ = stump_opacity;
    show_bones_ = bones;
    show_landmarks_ = landmarks;
    show_socket_ = socket;
  }
  void select_spot(int index) {
    selected_spot_ = index;
    scroll_to_selected_ = true;
  }

  // ---- Frame ----------------------------------------------------------------------------------
  /// Builds the UI and renders one frame into the current framebuffer (width × height).
  void frame(int width, int height);
  /// Nothing loading, solving, optimising or exporting.
  bool is_idle() const { return session_.is_idle(); }
  Field field() const { return field_; }
  /// The colour bar's range (the values at its bottom and top, in the field's unit).
  std::pair<float, float> colour_range() const { return {range_min_, range_max_}; }
  OrbitCamera& camera() { return camera_; }
  /// Writes the last rendered frame as PNG. @throws IoError.
  void screenshot(const std::filesystem::path& path, int width, int height) const;
  /// Called when the window is asked to close: true when it may close now.
  bool request_close();

 private:
  /// Saves to the case's own file, or asks for one; an error is shown by the session.
  void save();
  /// Brings the GPU data and the colours up to what the session shows (its serials changed).
  void follow_session();
  void install_scene();
  void update_brim();
  void update_meshes();
  void update_colours();

  void draw_menu();
  void draw_design_panel();
  void draw_spot(int k);
  void draw_brim_panel();
  void draw_patient_panel();
  void draw_feedback_panel();
  void draw_template_check();
  void draw_rectification();
  void draw_delivery();
  void draw_viewport_overlay(int x, int y, int width, int height);
  void draw_view_controls(int x, int y);
  void draw_file_dialog();
  void draw_close_dialog();
  void handle_view_input(int x, int y, int width, int height);
  void show_hover(int x, int y, int width, int height);
  void render_scene(int x, int y, int width, int height, int framebuffer_height);
  void draw_scene(int width, int height);

  GLFWwindow* window_;
  bool is_headless_;
  pipeline::DesignSession session_;
  /// The session's serials when the view last followed it.
  std::uint64_t seen_setup_ = 0, seen_brim_ = 0, seen_state_ = 0, seen_comparison_ = 0, seen_rectification_ = 0,
                seen_delivery_ = 0;
  bool is_rectification_table_opening_ = false;  // set_field(Rectification) opens its table once
  bool is_delivery_table_opening_ = false;       // set_field(Delivered or DeliveryError): its section
  /// The libraries' log lines (any thread), newest last, for the Log panel.
  struct LogLines {
    std::mutex mutex;
    std::vector<std::string> lines;
  };
  std::shared_ptr<LogLines> log_ = std::make_shared<LogLines>();

  // View
  OrbitCamera camera_;
  std::unique_ptr<MeshRenderer> renderer_;
  SceneTarget scene_target_;
  std::array<double, 12> scene_key_{};
  std::uint64_t scene_version_ = 0;  // bumped whenever GPU data of the scene changes
  GpuMesh stump_, socket_;
  std::vector<std::unique_ptr<GpuMesh>> bones_;
  GpuLines brim_lines_;
  Field field_ = Field::Pressure;
  bool is_auto_range_ = true;
  float range_min_ = 0, range_max_ = 100;
  bool show_bones_ = true, show_landmarks_ = true, show_socket_ = true, show_brim_ = true;
  float socket_alpha_ = 0.3f;
  float stump_alpha_ = 1.0f;
  bool scroll_to_selected_ = false;
  bool colours_dirty_ = true;
  bool is_placing_spot_ = false;
  int new_spot_type_ = 0;
  float new_spot_amplitude_kpa_ = 20;
  float optimise_time_limit_s_ = 0;  ///< the optimiser's wall-time bound [s]; 0 = none
  int selected_spot_ = -1;
  int selected_key_point_ = -1;
  bool is_dragging_view_ = false;
  double drag_distance_px_ = 0;

  // Dialogs
  enum class Dialog { None, OpenCase, OpenLimb, SaveAs, Export, Compare } dialog_ = Dialog::None;
  std::string dialog_path_;
  std::string dialog_folder_;
  int dialog_target_nodes_ = 8000;
  bool is_close_requested_ = false;
};

}  // namespace socketsmith::gui
