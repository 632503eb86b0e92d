#pragma once
/// @file app.h
/// socketsmith-gui's application: the open case (document, undo/redo, autosave), the prepared
/// stump (pipeline::DesignSetup) with its solve worker, the panels and the 3D view. One frame()
/// per displayed frame; everything slow (preparing a case, solving, optimising, exporting) runs
/// off the UI thread, and every error is shown in the window with the user's work kept.

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "design_worker.h"
#include "viewport.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/prosthetist_checks.h"
#include "socketsmith/report/design_report.h"

struct GLFWwindow;

namespace socketsmith::gui {

/// The field the stump is coloured by. Deviation: the signed distance from the stump's skin to a
/// second shape (compare_with), > 0 where that shape lies outside. Rectification: socket minus
/// limb (pipeline::compute_rectification), < 0 where the socket indents the tissue.
enum class Field { Pressure, Threshold, Ratio, Displacement, Deviation, Rectification };
const char* to_string(Field field);
/// "pressure" | "threshold" | "ratio" | "displacement" | "deviation" | "rectification";
/// @throws InvalidInputError otherwise.
Field parse_field(const std::string& text);

/// One row of the rectification table as the window draws it.
struct RectificationRow {
  std::string code, name;  ///< the landmark
  double mm = 0;           ///< socket − limb [mm]; NaN above the brim
  std::string value;       ///< as shown: "-2.41", or "-" above the brim
  std::string kind;        ///< pipeline::rectification_kind: indentation, relief, above the brim
  std::string measured;    ///< "radially" or "along the axis"
};

/// The rectification chart of one design: socket minus limb on the skin and at each landmark, as
/// the report computes it (pipeline::designed_wall, pipeline::compute_rectification).
struct RectificationChart {
  pipeline::Rectification rectification;
  std::string wall_source;    ///< what the socket is ("the socket's inner wall", ...)
  std::string error;          ///< set when it could not be computed
  double seconds = 0;         ///< the time it took (socket and chart), on its own thread
  std::uint64_t setup = 0;    ///< which setup and which shown state it belongs to
  std::uint64_t state = 0;
};

/// A background job (prepare a case, export) with its progress.
struct BackgroundJob {
  std::string what;                          ///< "loading demo", "exporting to …"
  std::future<void> done;
  std::shared_ptr<std::atomic<double>> fraction = std::make_shared<std::atomic<double>>(0.0);
  std::shared_ptr<std::mutex> stage_mutex = std::make_shared<std::mutex>();
  std::shared_ptr<std::string> stage = std::make_shared<std::string>();
};

class App {
 public:
  App(GLFWwindow* window, bool is_headless);
  ~App();
  App(const App&) = delete;
  App& operator=(const App&) = delete;

  // ---- Document -------------------------------------------------------------------------------
  /// Opens a case file (prepared on a worker thread; the current case stays until it is ready).
  void open_case(const std::filesystem::path& path);
  /// Opens the demo sample (generated limb) at @p target_nodes.
  void open_demo(int target_nodes);
  /// Opens a limb scan (STL/OBJ/PLY/AOP) as a new case with the default design.
  void open_limb(const std::filesystem::path& path, int target_nodes);
  /// Saves the case atomically (the spots, brim, thickness and patient as edited).
  /// @throws Error when it cannot be written (also shown in the window).
  void save_case(const std::filesystem::path& path);
  /// Writes the design's outputs (socket STL, report, maps) to @p dir on a worker thread:
  /// pipeline::run_design on the case as edited, not optimised — the same as
  /// `socketsmith design CASE --no-optimise`.
  void export_design(const std::filesystem::path& dir);
  /// Compares a second shape of the limb (a later scan, a socket solid: its cavity) with the open
  /// limb on a worker thread, as `socketsmith compare LIMB SHAPE` does (geometry::compare_shapes:
  /// aligned by the limb frames, ICP), and colours the stump by the deviation [mm] once done.
  void compare_with(const std::filesystem::path& path);
  /// Per skin node: the deviation of the compared shape [m] (NaN where it does not cover the skin);
  /// empty before a comparison (and after another case is opened).
  const std::vector<double>& deviation_m() const { return deviation_m_; }
  const std::string& comparison() const { return comparison_; }  ///< what was compared, one line
  void undo();
  void redo();

  // ---- Design edits (each one undoable, each one starts a solve) -------------------------------
  /// Adds a spot of @p type centred at the skin point nearest @p point (world [m]).
  /// @throws InvalidInputError when no case is loaded or the point is off the limb.
  void add_spot_at(const Vec3& point, design::SpotType type, double amplitude_pa);
  /// Adds a spot at landmark @p code. @throws InvalidInputError for an unknown code.
  void add_spot_at_landmark(const std::string& code, design::SpotType type, double amplitude_pa);
  /// Sets one field of spot @p index in clinical units (amplitude_kpa, theta0_deg, r_theta_deg,
  /// h0_mm, r_h_mm, theta1_deg, theta2_deg, h1_mm, h2_mm, enabled).
  /// @throws InvalidInputError for an unknown field or spot.
  void set_spot_value(int index, const std::string& field, double value);
  int spot_index(const std::string& name) const;
  /// @throws InvalidInputError when it is the last spot (a case without spots would replay as the
  ///         default layout).
  void remove_spot(int index);
  void set_brim_template(design::BrimTemplate kind);
  void move_brim_key_point(int index, double theta_rad, double h_m);
  void set_thickness(double thickness_m);
  /// The patient panel's values (applied to the stump model by "Apply"), checked like the case
  /// file's (design/input_limits.h). @throws InvalidInputError naming the value and its range.
  void set_patient(const design::PatientLoad& patient, double youngs_modulus_pa, const design::ThresholdTable& thresholds);
  /// Optimises the spots on the worker; @p time_limit_s > 0 bounds its wall time [s].
  void optimise(double time_limit_s = 0);
  void cancel_optimise();
  /// Colours the stump by @p field; Rectification also asks for the rectification chart, kept up to
  /// date after every design from then on.
  void set_field(Field field);
  /// The chart of the shown design, or nullptr while it is computed (or before it was asked for).
  const RectificationChart* rectification() const;
  /// The landmark table of rectification() as drawn (empty without a chart).
  std::vector<RectificationRow> rectification_rows() const;
  /// A continuous edit (a slider drag) starts / ends: its changes make one undo step.
  void begin_edit();
  /// The end of a slider drag: the previews that served it are replaced by a full solve.
  void end_edit();
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
  bool is_idle() const;
  bool has_design() const { return setup_ != nullptr; }
  bool has_state() const { return state_.has_value(); }
  const design::CaseFile& document() const { return case_; }
  const std::optional<design::DesignState>& state() const { return state_; }
  Field field() const { return field_; }
  /// The colour bar's range (the values at its bottom and top, in the field's unit).
  std::pair<float, float> colour_range() const { return {range_min_, range_max_}; }
  /// The shown state read against its brim template (what the "Template regions" panel shows).
  const std::optional<design::TemplateCheck>& template_check() const { return template_; }
  const std::vector<std::string>& errors() const { return errors_; }
  long solves_done() const { return worker_ ? worker_->solves_done() : 0; }
  OrbitCamera& camera() { return camera_; }
  /// Writes the last rendered frame as PNG. @throws IoError.
  void screenshot(const std::filesystem::path& path, int width, int height) const;
  /// Shows the error in the window (and stderr in headless mode).
  void show_error(const std::string& message);
  /// Called when the window is asked to close: true when it may close now.
  bool request_close();

 private:
  /// Prepares @p c on a worker thread; installed by poll_jobs() when ready.
  /// @p is_rebuild: the same case with new patient data (edits, history and dirty flag kept).
  void load(design::CaseFile c, std::filesystem::path path, const std::string& what, bool is_rebuild = false);
  void start_job(const std::string& what, std::function<void(const ProgressCallback&)> work);
  void poll_jobs();
  void poll_worker();
  void install_setup(std::unique_ptr<pipeline::DesignSetup> setup, design::CaseFile c, std::filesystem::path path);
  void edit(const std::function<void()>& change, bool brim_changed = false);
  void push_history();
  /// Undo (from = undo, to = redo) or redo: the case goes back to from's last snapshot.
  void step_history(std::vector<design::CaseFile>& from, std::vector<design::CaseFile>& to);
  void request_solve(bool brim_changed);
  void autosave();
  void update_brim();
  void update_meshes();
  void update_colours();
  void update_feedback();
  /// Installs a finished rectification chart and starts the next one when the shown design changed
  /// (on a thread of its own, from copies: the solver goes on meanwhile).
  void poll_rectification();

  void draw_menu();
  void draw_design_panel();
  void draw_patient_panel();
  void draw_feedback_panel();
  void draw_template_check();
  void draw_rectification();
  void draw_viewport_overlay(int x, int y, int width, int height);
  void draw_file_dialog();
  void draw_close_dialog();
  void handle_view_input(int x, int y, int width, int height);
  void render_scene(int x, int y, int width, int height, int framebuffer_height);
  void draw_scene(int width, int height);

  GLFWwindow* window_;
  bool is_headless_;

  // Document
  design::CaseFile case_;
  std::filesystem::path case_path_;
  bool is_dirty_ = false;
  std::vector<design::CaseFile> undo_, redo_;
  std::optional<design::CaseFile> edit_start_;  // the case when a slider drag began
  std::chrono::steady_clock::time_point last_autosave_ = std::chrono::steady_clock::now();

  // Prepared stump, worker, results
  std::unique_ptr<pipeline::DesignSetup> setup_;
  std::unique_ptr<DesignWorker> worker_;
  std::optional<BackgroundJob> job_;
  std::unique_ptr<pipeline::DesignSetup> loaded_;  // handed over by a finished load job
  design::CaseFile loaded_case_;
  std::filesystem::path loaded_path_;
  bool loaded_is_rebuild_ = false;
  std::string job_message_;  // set by a finished job, shown by poll_jobs()
  std::optional<std::vector<double>> compared_;  // handed over by a finished comparison job
  std::string compared_label_, compared_file_;
  std::vector<double> deviation_m_;  // the installed comparison, per skin node
  std::string comparison_, comparison_file_;
  std::mutex loaded_mutex_;
  std::uint64_t generation_ = 0;
  std::optional<design::DesignState> state_;
  std::vector<report::RadarAxis> radar_;
  std::optional<design::TemplateCheck> template_;  // the state read against its brim template
  std::uint64_t setup_serial_ = 0, state_serial_ = 0;  // bumped per installed setup / shown state
  bool is_rectification_asked_ = false;
  bool is_rectification_table_opening_ = false;  // set_field(Rectification) opens its table once
  std::optional<RectificationChart> rectification_;    // of the shown state, or of an earlier one
  std::future<RectificationChart> rectification_job_;
  std::vector<report::PathProfile> profiles_;
  std::string solve_status_;
  std::string optimiser_message_;
  bool is_optimising_ = false;
  std::vector<std::string> errors_;
  std::string info_;
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
  geometry::TriMesh skin_rest_;      // skin triangles, local ids = skin order [m]
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
