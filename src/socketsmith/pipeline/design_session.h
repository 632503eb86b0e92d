#pragma once
/// @file design_session.h
/// One case as the interactive design edits it, without a window: the case document, edits in
/// clinical units (each one undoable, each one starting a design solve), undo/redo, autosave, the
/// prepared stump with its solve worker (design_worker.h), the results a window draws (the design
/// state, radar, pressure profiles, template regions, rectification chart, what the socket
/// delivers, a compared shape's deviation), save and export. Everything slow (preparing a case, solving, optimising, exporting,
/// comparing, the rectification chart, the delivery check) runs on other threads; poll() installs what finished and
/// the serials say what changed. socketsmith-gui's App draws a session and turns input into its
/// calls (docs/gui.md); tests drive one without a display (tests/pipeline/design_session_test.cpp).
///
/// One thread (the caller's, the window's) calls a session; its workers hand results over through
/// poll(). Errors of edits made on a window are shown there, so the session keeps them as lines
/// (errors()) as well as throwing where the call says so.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/core/progress.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/design/template_regions.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/design_worker.h"
#include "socketsmith/pipeline/prosthetist_checks.h"
#include "socketsmith/report/design_report.h"

namespace socketsmith::pipeline {

/// One row of the rectification table as a window shows it.
struct RectificationRow {
  std::string code, name;  ///< the landmark
  double mm = 0;           ///< socket − limb [mm]; NaN above the brim
  std::string value;       ///< as shown: "-2.41", or "-" above the brim
  std::string kind;        ///< rectification_kind: indentation, relief, above the brim
  std::string measured;    ///< "radially" or "along the axis"
};

/// The rectification chart of one design: socket minus limb on the skin and at each landmark, as
/// the report computes it (designed_wall, compute_rectification).
struct RectificationChart {
  Rectification rectification;
  std::string wall_source;    ///< what the socket is ("the socket's inner wall", ...)
  std::string error;          ///< set when it could not be computed
  double seconds = 0;         ///< the time it took (socket and chart), on its own thread
  std::uint64_t setup = 0;    ///< which setup and which shown state it belongs to
  std::uint64_t state = 0;
};

/// What the socket of the shown design delivers (docs/gui.md, "Delivered"): the socket *Export*
/// would write, donned and stood on (friction, half the body weight) and its wall corrected until
/// it delivers the design — the closed loop `socketsmith design` runs (close_design_loop), on the
/// case as edited, prepared and solved afresh on a thread of its own.
struct DeliveryCheck {
  std::vector<double> target_pa;       ///< designed, per skin node (0 above the brim) [Pa]
  std::vector<double> open_loop_pa;    ///< delivered by the open-loop socket, per skin node [Pa]
  std::vector<double> closed_loop_pa;  ///< delivered by the corrected socket (the one exported) [Pa]
  std::vector<char> below_brim;        ///< skin nodes compared (1: below the brim)
  DeliverySummary summary;             ///< by region and at the landmarks, as the report's table
  bool converged = false;              ///< the loop met its tolerances
  int donnings = 0, refits = 0;        ///< what it ran
  std::string message;                 ///< how the loop ended, one line
  std::string error;                   ///< set when it could not run (then nothing else is)
  double seconds = 0;                  ///< the whole check: preparing, solving, the loop
  std::uint64_t setup = 0;             ///< which setup and which shown state it belongs to
  std::uint64_t state = 0;
};

/// A background job (prepare a case, export, compare) with its progress.
struct SessionJob {
  std::string what;                          ///< "opening the demo", "exporting to …"
  std::future<void> done;
  std::shared_ptr<std::atomic<double>> fraction = std::make_shared<std::atomic<double>>(0.0);
  std::shared_ptr<std::mutex> stage_mutex = std::make_shared<std::mutex>();
  std::shared_ptr<std::string> stage = std::make_shared<std::string>();
  /// The stage line as last reported (any thread may report it).
  std::string stage_text() const;
  /// A callback that keeps the fraction and stage here; it asks to stop once @p cancel is set.
  ProgressCallback reporter(std::shared_ptr<std::atomic<bool>> cancel = nullptr) const;
};

class DesignSession {
 public:
  DesignSession();
  ~DesignSession();
  DesignSession(const DesignSession&) = delete;
  DesignSession& operator=(const DesignSession&) = delete;

  // ---- Document -------------------------------------------------------------------------------
  /// Opens a case file (prepared on a worker thread; the current case stays until it is ready).
  void open_case(const std::filesystem::path& path);
  /// Opens the demo sample (generated limb) at @p target_nodes.
  void open_demo(int target_nodes);
  /// Opens a limb scan (STL/OBJ/PLY/AOP) as a new case with the default design.
  void open_limb(const std::filesystem::path& path, int target_nodes);
  /// Rebuilds the stump model of the open case with its patient values (the patient panel's
  /// "Apply"), on a worker thread; the edits, their history and the unsaved flag stay.
  void rebuild();
  /// Installs case @p c on its prepared stump now (a load's end; the tests prepare their own):
  /// the history is cleared and the first solve requested. @p path: where the case was read.
  void install(std::unique_ptr<DesignSetup> setup, design::CaseFile c, std::filesystem::path path = {});
  /// Saves the case atomically (the spots, brim, thickness and patient as edited; limb paths
  /// absolute, so the case can move). @throws Error when it cannot be written (also in errors()).
  void save_case(const std::filesystem::path& path);
  /// Writes the design's outputs (socket STL, report, maps) to @p dir on a worker thread:
  /// run_design on the case as edited, not optimised — the same as
  /// `socketsmith design CASE --no-optimise`.
  void export_design(const std::filesystem::path& dir);
  /// Compares a second shape of the limb (a later scan, a socket solid: its cavity) with the open
  /// limb on a worker thread, as `socketsmith compare LIMB SHAPE` does (geometry::compare_shapes:
  /// aligned by the limb frames, ICP); deviation_m() once done.
  void compare_with(const std::filesystem::path& path);
  /// Where autosave() writes: `<case>.autosave.json`, or `socketsmith_autosave.json` (in the
  /// working folder) for a case never saved.
  std::filesystem::path autosave_path() const;
  /// Writes the case to autosave_path() (atomically, as save_case) when it has unsaved changes and
  /// @p interval has passed since the last autosave (or the session began) at @p now.
  /// @return true when it wrote the file. A failure is one line in errors().
  bool autosave(std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now(),
                std::chrono::steady_clock::duration interval = std::chrono::seconds(60));
  /// Forgets that the case has unsaved changes (the window closes without saving).
  void discard_changes() { is_dirty_ = false; }

  // ---- Edits (each one undoable, each one starts a solve) --------------------------------------
  /// Adds a spot of @p type centred at the skin point nearest @p point (world [m]), named after the
  /// nearest landmark within 30 mm. @throws InvalidInputError when no case is open or the point is
  /// off the limb.
  void add_spot_at(const Eigen::Vector3d& point, design::SpotType type, double amplitude_pa);
  /// Adds a spot at landmark @p code, named "CODE (added)". @throws InvalidInputError for an
  /// unknown code.
  void add_spot_at_landmark(const std::string& code, design::SpotType type, double amplitude_pa);
  /// Sets one field of spot @p index in clinical units (amplitude_kpa, theta0_deg, r_theta_deg,
  /// h0_mm, r_h_mm, theta1_deg, theta2_deg, h1_mm, h2_mm, enabled; optimise_amplitude and
  /// optimise_position as set_spot_freedom).
  /// @throws InvalidInputError for an unknown field or spot, or a value the spot cannot take.
  void set_spot_value(int index, const std::string& field, double value);
  /// The index of the spot named @p name, -1 when there is none.
  int spot_index(const std::string& name) const;
  /// What the optimiser may change of spot @p index (no undo step, as the check boxes always were).
  void set_spot_freedom(int index, bool amplitude, bool position);
  /// @throws InvalidInputError when it is the last spot (a case without spots would replay as the
  ///         default layout). An index out of range does nothing.
  void remove_spot(int index);
  /// An invalid brim (outside the limb) is refused: one line in errors(), the case unchanged.
  void set_brim_template(design::BrimTemplate kind);
  void move_brim_key_point(int index, double theta_rad, double h_m);
  void set_thickness(double thickness_m);
  /// The patient panel's values (applied to the stump model by rebuild()), checked like the case
  /// file's (design/input_limits.h). @throws InvalidInputError naming the value and its range.
  void set_patient(const design::PatientLoad& patient, double youngs_modulus_pa, const design::ThresholdTable& thresholds);
  /// Optimises the spots on the worker; @p time_limit_s > 0 bounds its wall time [s].
  void optimise(double time_limit_s = 0);
  void cancel_optimise();
  /// A continuous edit (a slider drag) starts: its changes make one undo step, and their solves are
  /// previews (the tangent's quick answer).
  void begin_edit();
  /// The end of a slider drag: the previews that served it are replaced by a full solve.
  void end_edit();
  void undo();
  void redo();
  bool can_undo() const { return !undo_.empty(); }
  bool can_redo() const { return !redo_.empty(); }

  /// One edit given as a headless script action (docs/gui.md): add_spot, set, remove_spot,
  /// optimise, cancel, patient, brim, brim_key_point, thickness, undo, redo, save, export, compare.
  /// @throws InvalidInputError for another action or a bad field (as the typed calls throw).
  void apply(const nlohmann::json& action);
  /// The edits made since the case was opened (by the calls above or apply), as the actions that
  /// apply() replays to the same case and the same socket; a list a `--script` file can hold.
  const nlohmann::json& journal() const { return journal_; }
  static bool is_edit_action(const std::string& action);

  // ---- Results --------------------------------------------------------------------------------
  /// Installs what the workers finished: a prepared case, a comparison, solve and optimiser
  /// results, a rectification chart (and starts the next chart when one is due). Call it often
  /// (each frame).
  void poll();
  /// Nothing loading, solving, optimising, exporting or charting.
  bool is_idle() const;
  /// poll()s until is_idle() or @p timeout has passed; true when idle.
  bool wait_idle(std::chrono::steady_clock::duration timeout = std::chrono::minutes(5));
  /// Asks for the rectification chart, kept up to date after every design from then on.
  void ask_rectification() { is_rectification_asked_ = true; }
  bool is_rectification_asked() const { return is_rectification_asked_; }
  /// The chart of the shown limb, or nullptr while it is computed (or before it was asked for).
  const RectificationChart* rectification() const;
  /// Why the chart of the shown limb could not be computed; empty otherwise.
  std::string rectification_error() const;
  /// The landmark table of rectification() as shown (empty without a chart).
  std::vector<RectificationRow> rectification_rows() const;
  /// Asks for the delivery check (DeliveryCheck), run once each design has settled — no solve
  /// waiting, no slider held, no optimisation running — with every constraint met (else there is
  /// no socket to don); an edit while it runs stops it, and it starts again on the new design.
  void ask_delivery() { is_delivery_asked_ = true; }
  /// Stops asking (and stops a check that runs); the last check stays shown.
  void stop_delivery();
  bool is_delivery_asked() const { return is_delivery_asked_; }
  /// The last check of the shown limb (maybe of a design before: its `state`), nullptr before one.
  const DeliveryCheck* delivery() const;
  /// Why the last check of the shown limb could not run; empty otherwise.
  std::string delivery_error() const;
  bool is_checking_delivery() const { return delivery_job_.has_value(); }
  /// The running check's fraction [0, 1] and stage; {-1, ""} when none runs.
  std::pair<double, std::string> delivery_progress() const;

  /// The socket as shown: the designed skin below the brim moved out by the wall thickness (its
  /// outer wall), on the rest skin's triangles; empty before a solve.
  geometry::TriMesh socket_preview() const;

  bool has_design() const { return setup_ != nullptr; }
  const DesignSetup* setup() const { return setup_.get(); }
  const design::CaseFile& document() const { return case_; }
  const std::filesystem::path& path() const { return case_path_; }
  bool is_dirty() const { return is_dirty_; }
  /// The skin's triangles at rest, local ids = skin order [m] (empty before a case).
  const geometry::TriMesh& skin_rest() const { return skin_rest_; }
  const std::optional<design::DesignState>& state() const { return state_; }
  const std::vector<report::RadarAxis>& radar() const { return radar_; }
  const std::vector<report::PathProfile>& profiles() const { return profiles_; }
  /// The shown state read against its brim template.
  const std::optional<design::TemplateCheck>& template_check() const { return template_; }
  /// Per skin node: the deviation of the compared shape [m] (NaN where it does not cover the skin);
  /// empty before a comparison (and after another limb is opened).
  const std::vector<double>& deviation_m() const { return deviation_m_; }
  const std::string& comparison() const { return comparison_; }  ///< what was compared, one line
  const std::string& comparison_file() const { return comparison_file_; }
  const std::optional<SessionJob>& job() const { return job_; }
  bool is_optimising() const { return is_optimising_; }
  bool is_solving() const { return worker_ && worker_->is_busy(); }
  /// The running optimisation's fraction [0, 1] and stage.
  std::pair<double, std::string> optimiser_progress() const;
  const std::string& optimiser_message() const { return optimiser_message_; }
  const std::string& solve_status() const { return solve_status_; }
  long solves_done() const { return worker_ ? worker_->solves_done() : 0; }

  /// Bumped when a case is installed, the brim line changes, a state is shown, a comparison is
  /// installed or dropped, a rectification chart is installed: what a view must redraw.
  std::uint64_t setup_serial() const { return setup_serial_; }
  std::uint64_t brim_serial() const { return brim_serial_; }
  std::uint64_t state_serial() const { return state_serial_; }
  std::uint64_t comparison_serial() const { return comparison_serial_; }
  std::uint64_t rectification_serial() const { return rectification_serial_; }
  std::uint64_t delivery_serial() const { return delivery_serial_; }  ///< bumped when a check is installed

  /// The last errors (one line each, newest last, at most 20) and the last note ("saved …").
  const std::vector<std::string>& errors() const { return errors_; }
  void clear_errors() { errors_.clear(); }
  const std::string& info() const { return info_; }
  /// Keeps @p message in errors() and logs it.
  void show_error(const std::string& message);

 private:
  /// Prepares @p c on a worker thread; installed by poll() when ready.
  /// @p is_rebuild: the same case with new patient data (edits, history and dirty flag kept).
  /// @return false when another job still runs (one line in errors()).
  bool load(design::CaseFile c, std::filesystem::path path, const std::string& what, bool is_rebuild = false);
  bool start_job(const std::string& what, std::function<void(const ProgressCallback&)> work);
  void poll_jobs();
  void poll_worker();
  void poll_rectification();
  void start_rectification();
  void poll_delivery();
  /// The last check is of the shown limb and design.
  bool is_delivery_current() const {
    return delivery_ && delivery_->setup == setup_serial_ && delivery_->state == state_serial_;
  }
  void start_delivery();
  void update_feedback();
  void edit(const std::function<void()>& change, bool brim_changed = false);
  void push_history();
  /// Undo (from = undo, to = redo) or redo: the case goes back to from's last snapshot.
  bool step_history(std::vector<design::CaseFile>& from, std::vector<design::CaseFile>& to);
  void request_solve(bool brim_changed);
  void add_spot(const Eigen::Vector3d& point, design::SpotType type, double amplitude_pa, const std::string& name);
  void record(nlohmann::json action);

  // Document
  design::CaseFile case_;
  std::filesystem::path case_path_;
  bool is_dirty_ = false;
  std::vector<design::CaseFile> undo_, redo_;
  std::optional<design::CaseFile> edit_start_;  // the case when a slider drag began
  std::chrono::steady_clock::time_point last_autosave_ = std::chrono::steady_clock::now();
  nlohmann::json journal_ = nlohmann::json::array();

  // Prepared stump, worker, jobs
  std::unique_ptr<DesignSetup> setup_;
  std::unique_ptr<DesignWorker> worker_;
  geometry::TriMesh skin_rest_;
  std::optional<SessionJob> job_;
  std::mutex loaded_mutex_;                // guards what a finished job hands over:
  std::unique_ptr<DesignSetup> loaded_;    //   a prepared case
  design::CaseFile loaded_case_;
  std::filesystem::path loaded_path_;
  bool loaded_is_rebuild_ = false;
  std::string job_message_;                //   a line for info()
  std::optional<std::vector<double>> compared_;  //   a comparison
  std::string compared_label_, compared_file_;
  std::uint64_t generation_ = 0;

  // Results
  std::optional<design::DesignState> state_;
  std::vector<report::RadarAxis> radar_;
  std::vector<report::PathProfile> profiles_;
  std::optional<design::TemplateCheck> template_;
  std::vector<double> deviation_m_;
  std::string comparison_, comparison_file_;
  bool is_rectification_asked_ = false;
  std::optional<RectificationChart> rectification_;  // of the shown state, or of an earlier one
  std::future<RectificationChart> rectification_job_;
  bool is_delivery_asked_ = false;
  std::optional<DeliveryCheck> delivery_;  // of the shown limb, or of an earlier one
  struct DeliveryJob {
    std::future<DeliveryCheck> done;
    std::uint64_t setup = 0, state = 0;  // the design it checks
    std::shared_ptr<std::atomic<bool>> cancel = std::make_shared<std::atomic<bool>>(false);
    SessionJob progress;                 // its fraction and stage (progress.done unused: `done` above)
  };
  std::optional<DeliveryJob> delivery_job_;
  std::string solve_status_, optimiser_message_;
  bool is_optimising_ = false;
  std::uint64_t setup_serial_ = 0, brim_serial_ = 0, state_serial_ = 0, comparison_serial_ = 0,
                rectification_serial_ = 0, delivery_serial_ = 0;
  std::vector<std::string> errors_;
  std::string info_;
};

}  // namespace socketsmith::pipeline
