// The Python extension socketsmith._core: thin pybind11 bindings over the library calls the
// `socketsmith` command makes (pipeline::prepare_design / solve_design / run_design /
// write_design_outputs, geometry::read_mesh / check_mesh, contact::simulate_donning,
// pipeline::validate_design). No design
// logic lives here: a design from Python is the CLI's design, number for number.
//
// Arrays: fields of a design are NumPy views (read-only) of the C++ vectors, kept alive by the
// Python object that owns them (the array's base), so a 100k-node stump costs no copy. Small
// values (the radar) are copied.
// Errors: every C++ exception becomes a Python exception classified by core/exit_status.h, with
// the same one-line message the CLI prints after "error: ".
// Progress: a Python callable (fraction, stage) -> bool|None; the GIL is released while C++ works
// and taken again only for the callback.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "socketsmith/contact/donning.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/exit_status.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/mesh_report.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/design_validation.h"

namespace py = pybind11;
namespace fs = std::filesystem;
using namespace socketsmith;
using geometry::Vec3;

namespace {

// ---------------------------------------------------------------------------------------------
// JSON across the boundary: through Python's json module, so a case dict is read by the same
// parser (design::parse_case) as a case file and a summary comes back as plain dicts and lists.

nlohmann::json to_json(const py::handle& obj) {
  const py::object dumps = py::module_::import("json").attr("dumps");
  return nlohmann::json::parse(dumps(obj, py::arg("allow_nan") = false).cast<std::string>());
}

py::object from_json(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

// ---------------------------------------------------------------------------------------------
// Exceptions: socketsmith.Error and one subclass per exit code of the CLI.

struct ExceptionTypes {
  py::object error, invalid_input, io, solver, topology, internal;
};
ExceptionTypes& exception_types() {
  static ExceptionTypes* types = new ExceptionTypes();  // never destroyed: lives as long as the interpreter
  return *types;
}

py::object make_exception(py::module_& m, const char* name, py::tuple bases, const char* doc) {
  const std::string full = std::string("socketsmith.") + name;
  py::object type = py::reinterpret_steal<py::object>(
      PyErr_NewExceptionWithDoc(full.c_str(), doc, bases.ptr(), nullptr));
  if (!type) throw py::error_already_set();
  m.add_object(name, type);
  return type;
}

void raise_status(const ExitStatus& status) {
  const auto& t = exception_types();
  const py::object& type = status.code == kExitBadInput         ? t.invalid_input
                           : status.code == kExitFileError      ? t.io
                           : status.code == kExitSolverDiverged ? t.solver
                           : status.code == kExitBadTopology    ? t.topology
                                                                : t.internal;
  py::object e = type(status.message);
  e.attr("exit_code") = status.code;
  PyErr_SetObject(type.ptr(), e.ptr());
}

// ---------------------------------------------------------------------------------------------
// Progress: a Python callable behind a ProgressCallback. An exception in the callable cancels the
// C++ work (the callback returns false) and is raised again once it has returned.

struct PythonProgress {
  py::object fn;
  std::optional<py::error_already_set> error;
};

ProgressCallback progress_callback(const std::shared_ptr<PythonProgress>& state) {
  if (!state || state->fn.is_none()) return {};
  return [state](double fraction, std::string_view stage) -> bool {
    py::gil_scoped_acquire gil;
    if (state->error) return false;
    try {
      const py::object r = state->fn(fraction, std::string(stage));
      return r.is_none() || r.cast<bool>();
    } catch (py::error_already_set& e) {
      state->error.emplace(std::move(e));
      return false;
    }
  };
}

/// Runs @p work without the GIL, with @p progress as its callback; raises the callback's own
/// exception, if it threw, after the work returns.
template <class F>
auto run_released(const py::object& progress, F&& work) {
  auto state = std::make_shared<PythonProgress>();
  state->fn = progress;
  const ProgressCallback cb = progress_callback(state);
  struct Rethrow {
    std::shared_ptr<PythonProgress>& s;
    void check() {
      if (s->error) {
        py::error_already_set e = std::move(*s->error);
        s->error.reset();
        throw e;
      }
    }
  } rethrow{state};
  try {
    if constexpr (std::is_void_v<decltype(work(cb))>) {
      {
        py::gil_scoped_release release;
        work(cb);
      }
      rethrow.check();
    } else {
      std::optional<decltype(work(cb))> out;
      {
        py::gil_scoped_release release;
        out.emplace(work(cb));
      }
      rethrow.check();
      return std::move(*out);
    }
  } catch (py::error_already_set&) {
    throw;
  } catch (...) {
    rethrow.check();  // the callback's exception explains a cancelled run best
    throw;
  }
}

// ---------------------------------------------------------------------------------------------
// NumPy views of C++ storage, owned by @p base (read-only: the library owns the data).

py::array readonly(py::array a) {
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

py::array view_vec3(const std::vector<Vec3>& v, py::handle base) {
  static_assert(sizeof(Vec3) == 3 * sizeof(double), "Vec3 is three packed doubles");
  return readonly(py::array_t<double>({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}},
                                      {static_cast<py::ssize_t>(sizeof(Vec3)), py::ssize_t{sizeof(double)}},
                                      v.empty() ? nullptr : v.data()->data(), base));
}

py::array view_doubles(const std::vector<double>& v, py::handle base) {
  return readonly(py::array_t<double>({static_cast<py::ssize_t>(v.size())}, {py::ssize_t{sizeof(double)}}, v.data(), base));
}

py::array view_ints(const std::vector<int>& v, py::handle base) {
  return readonly(py::array_t<int>({static_cast<py::ssize_t>(v.size())}, {py::ssize_t{sizeof(int)}}, v.data(), base));
}

template <size_t N>
py::array view_int_rows(const std::vector<std::array<int, N>>& v, py::handle base) {
  static_assert(sizeof(std::array<int, N>) == N * sizeof(int));
  return readonly(py::array_t<int>({static_cast<py::ssize_t>(v.size()), static_cast<py::ssize_t>(N)},
                                   {static_cast<py::ssize_t>(sizeof(std::array<int, N>)), py::ssize_t{sizeof(int)}},
                                   v.empty() ? nullptr : v.data()->data(), base));
}

/// A 3N vector as an (N, 3) view.
py::array view_xyz(const Eigen::VectorXd& v, py::handle base) {
  return readonly(py::array_t<double>({static_cast<py::ssize_t>(v.size() / 3), py::ssize_t{3}},
                                      {py::ssize_t{3 * sizeof(double)}, py::ssize_t{sizeof(double)}}, v.data(), base));
}

// ---------------------------------------------------------------------------------------------
// Cases: a dict (file units, docs/case_file.md) or the path of a case file.

design::CaseFile to_case(const py::object& c, const std::optional<std::string>& folder) {
  if (py::isinstance<py::str>(c) || py::hasattr(c, "__fspath__"))
    return design::read_case(py::str(py::module_::import("os").attr("fspath")(c)).cast<std::string>());
  if (!py::isinstance<py::dict>(c))
    throw InvalidInputError("case: expected a dict (the case file's JSON, docs/case_file.md) or the path of a case file");
  return design::parse_case(to_json(c), folder ? fs::path(*folder) : fs::current_path());
}

// ---------------------------------------------------------------------------------------------
// Owned objects.

struct Mesh {
  geometry::TriMesh mesh;
  geometry::MeshReadInfo info;
  std::string file;
};

/// Stage 1 of a design: the stump model of a case (pipeline::prepare_design).
struct Stump {
  std::unique_ptr<pipeline::DesignSetup> setup;
};

/// A solved design: the stump it was solved on and pipeline::DesignResult.
struct Design {
  std::shared_ptr<Stump> stump;
  pipeline::DesignResult result;
  nlohmann::json summary;  ///< design.json, when written
};

struct Donning {
  std::shared_ptr<Stump> stump;
  contact::DonningResult result;
  std::vector<double> pressure_pa;  ///< per candidate (skin) node
};

/// A CalculiX validation (pipeline::validate_design) and the design it checked.
struct Validation {
  pipeline::DesignValidation run;
  std::shared_ptr<Design> design;    ///< shares the run's stump and result
  std::shared_ptr<Donning> donning;  ///< socketsmith's own donning, when one ran
};

nlohmann::json check_json(const Mesh& m) { return geometry::mesh_report_json(m.file, m.mesh, m.info); }

geometry::MeshReadOptions read_options(const std::optional<std::string>& unit) {
  geometry::MeshReadOptions ro;
  if (unit) ro.unit = units::parse_length_unit(*unit);
  return ro;
}

std::shared_ptr<Mesh> read_mesh(const std::string& file, const std::optional<std::string>& unit) {
  auto m = std::make_shared<Mesh>();
  m->file = file;
  py::gil_scoped_release release;
  m->mesh = geometry::read_mesh(file, read_options(unit), &m->info);
  return m;
}

std::shared_ptr<Stump> prepare(const py::object& case_obj, const std::optional<int>& target_nodes,
                               const py::object& progress, const std::optional<std::string>& folder) {
  design::CaseFile c = to_case(case_obj, folder);
  if (target_nodes) c.target_nodes = *target_nodes;
  auto s = std::make_shared<Stump>();
  s->setup = run_released(progress, [&](const ProgressCallback& cb) { return pipeline::prepare_design(c, {}, cb); });
  return s;
}

std::shared_ptr<Design> solve(const std::shared_ptr<Stump>& stump, std::optional<bool> optimise,
                              const py::object& progress) {
  auto d = std::make_shared<Design>();
  d->stump = stump;
  const bool opt = optimise.value_or(stump->setup->case_file.optimise);
  d->result = run_released(progress, [&](const ProgressCallback& cb) {
    return pipeline::solve_design(*stump->setup, opt, cb);
  });
  return d;
}

std::shared_ptr<Design> run_design(const py::object& case_obj, const std::optional<std::string>& out,
                                   std::optional<bool> optimise, const std::optional<int>& target_nodes,
                                   double time_limit_s, const py::object& progress,
                                   const std::optional<std::string>& folder) {
  design::CaseFile c = to_case(case_obj, folder);
  if (target_nodes) c.target_nodes = *target_nodes;
  if (time_limit_s > 0) c.time_limit_s = time_limit_s;
  const bool opt = optimise.value_or(c.optimise);
  if (!out) {
    auto s = std::make_shared<Stump>();
    s->setup = run_released(progress, [&](const ProgressCallback& cb) {
      return pipeline::prepare_design(c, {}, [&cb](double f, std::string_view st) { return report_progress(cb, 0.45 * f, st); });
    });
    auto d = std::make_shared<Design>();
    d->stump = s;
    d->result = run_released(progress, [&](const ProgressCallback& cb) {
      return pipeline::solve_design(*s->setup, opt, [&cb](double f, std::string_view st) {
        return report_progress(cb, 0.45 + 0.55 * f, st);
      });
    });
    return d;
  }
  // The CLI's `socketsmith design CASE --out DIR`: the same call, the same files.
  auto d = std::make_shared<Design>();
  d->stump = std::make_shared<Stump>();
  run_released(progress, [&](const ProgressCallback& cb) {
    pipeline::DesignArtifacts art;
    d->summary = pipeline::run_design(c, *out, opt, cb, &art);
    d->stump->setup = std::move(art.setup);
    d->result = std::move(art.result);
  });
  return d;
}

py::array radar_array(const design::RadarValues& r) {
  py::array_t<double> a(7);
  auto p = a.mutable_unchecked<1>();
  for (int k = 0; k < 3; ++k) {
    p(k) = r.force_n[k];
    p(3 + k) = r.torque_nm[k];
  }
  p(6) = r.stability_n;
  return a;
}

std::shared_ptr<Donning> don(const std::shared_ptr<Design>& d, std::optional<double> friction, bool stand,
                             std::optional<double> step_mm, int steps, const py::object& progress) {
  const auto& setup = *d->stump->setup;
  if (!d->result.socket)
    throw InvalidInputError(
        "don: this design does not meet its constraints, so it has no socket to don; fix the design first");
  const auto& c = setup.case_file;
  contact::DonningOptions o;
  o.friction = friction.value_or(c.patient.friction);
  o.stand_force_n = stand ? 0.5 * c.patient.body_mass_kg * units::kGravity : 0.0;
  o.step_m = step_mm ? *step_mm * 1e-3 : c.closed_loop_step_m;
  o.steps = steps;
  auto out = std::make_shared<Donning>();
  out->stump = d->stump;
  out->result = run_released(progress, [&](const ProgressCallback& cb) {
    o.progress = cb;
    const auto& skin = setup.solver->skin();
    return contact::simulate_donning(setup.solver->model(), skin.nodes, skin.area_m2, d->result.socket->solid,
                                     setup.model.frame, o);
  });
  for (const auto& nc : out->result.contacts) out->pressure_pa.push_back(nc.pressure_pa);
  return out;
}

struct ValidateArgs {
  std::string mode, element, fe_pressure, ccx;
  bool against_donning = false, stand = false, nonlinear_body = false, neo_hookean = false, small_strain = false;
  std::optional<bool> optimise;
  std::optional<double> poisson, friction, penalty;  // penalty: empty, the default (DesignValidationOptions)
  double stick_slope = 5e7, clearance_mm = 1.0, travel_mm = 60.0, initial_increment = 0.05;
  int ccx_threads = 1;
  double ccx_time_limit_s = 3600;
  std::optional<int> target_nodes;
};

std::shared_ptr<Validation> validate(const py::object& case_obj, const std::string& out, const ValidateArgs& a,
                                     const py::object& progress, const std::optional<std::string>& folder) {
  design::CaseFile c = to_case(case_obj, folder);
  if (a.target_nodes) c.target_nodes = *a.target_nodes;
  pipeline::DesignValidationOptions o;
  o.mode = calculix::parse_design_check_mode(a.mode);
  o.against_donning = a.against_donning;
  o.stand = a.stand;
  o.nonlinear_body = a.nonlinear_body;
  o.optimise = a.optimise.value_or(true);
  o.poisson_ratio = a.poisson.value_or(-1.0);
  o.neo_hookean = a.neo_hookean;
  o.small_strain = a.small_strain;
  if (!a.element.empty()) o.element = calculix::parse_element_type(a.element);
  o.penalty_pa_per_m = a.penalty;
  o.stick_slope_pa_per_m = a.stick_slope;
  o.friction = a.friction.value_or(-1.0);
  o.clearance_m = a.clearance_mm * 1e-3;
  o.travel_m = a.travel_mm * 1e-3;
  o.initial_increment = a.initial_increment;
  o.fe_pressure = calculix::parse_fe_pressure(a.fe_pressure);
  o.ccx.executable = a.ccx;
  o.ccx.threads = a.ccx_threads;
  o.ccx.time_limit_s = a.ccx_time_limit_s;
  o.case_label = py::isinstance<py::dict>(case_obj) ? "dict" : py::str(case_obj).cast<std::string>();
  o.write_case = true;
  auto v = std::make_shared<Validation>();
  run_released(progress, [&](const ProgressCallback& cb) {
    // The design (and socketsmith's donning) take the first 40 %, CalculiX the rest.
    if (cb) {
      o.progress = [&cb](double f, std::string_view st) { return report_progress(cb, 0.4 * f, st); };
      o.ccx.progress = [&cb](double f, std::string_view st) { return report_progress(cb, 0.4 + 0.6 * f, st); };
    }
    v->run = pipeline::validate_design(c, o, out);
  });
  auto stump = std::make_shared<Stump>();
  stump->setup = std::move(v->run.artifacts.setup);  // the run's stump refers to the setup, which stays where it is
  v->design = std::make_shared<Design>();
  v->design->stump = stump;
  v->design->result = std::move(v->run.artifacts.result);
  v->design->summary = v->run.design_summary;
  if (v->run.donning) {
    v->donning = std::make_shared<Donning>();
    v->donning->stump = stump;
    v->donning->result = *v->run.donning;
    for (const auto& nc : v->donning->result.contacts) v->donning->pressure_pa.push_back(nc.pressure_pa);
  }
  return v;
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "socketsmith: prosthetic socket design from a residual-limb scan (C++ core; see docs/python.md)";

  // Exceptions (README, "Exit codes"): str(e) is the CLI's line without "error: ", e.exit_code its code.
  auto& t = exception_types();
  t.error = make_exception(m, "Error", py::make_tuple(py::handle(PyExc_RuntimeError)),
                           "Base of socketsmith's errors; exit_code is the CLI's exit code for it.");
  t.invalid_input = make_exception(m, "InvalidInputError", py::make_tuple(t.error, py::handle(PyExc_ValueError)),
                                   "Bad input: a value out of range, a file that is not a mesh, a case that does not fit its limb (exit code 1).");
  t.io = make_exception(m, "IoError", py::make_tuple(t.error, py::handle(PyExc_OSError)),
                        "A file could not be read or written (exit code 2).");
  t.solver = make_exception(m, "SolverError", py::make_tuple(t.error), "A solver diverged (exit code 3).");
  t.topology = make_exception(m, "TopologyError", py::make_tuple(t.error),
                              "A mesh has the wrong topology for the operation (exit code 4).");
  t.internal = make_exception(m, "InternalError", py::make_tuple(t.error), "A bug: please report it (exit code 70).");
  py::register_exception_translator([](std::exception_ptr p) {
    if (!p) return;
    try {
      std::rethrow_exception(p);
    } catch (const py::error_already_set&) {
      throw;
    } catch (const py::builtin_exception&) {
      throw;
    } catch (...) {
      raise_status(exit_status(std::current_exception()));
    }
  });

  m.def("set_log_level", [](const std::string& level) { log::set_level(log::parse_level(level)); }, py::arg("level"),
        "The library's log level on stderr: debug|info|warn|error|off (the module starts at warn).");
  log::set_level(log::Level::Warn);

  // Meshes.
  py::class_<Mesh, std::shared_ptr<Mesh>>(m, "Mesh", "A surface read from STL/OBJ/PLY/AOP, in metres.")
      .def_property_readonly("vertices", [](py::object self) { return view_vec3(self.cast<Mesh&>().mesh.vertices, self); },
                             "(V, 3) float64 [m], a read-only view")
      .def_property_readonly("triangles", [](py::object self) { return view_int_rows(self.cast<Mesh&>().mesh.triangles, self); },
                             "(T, 3) int32 vertex indices, a read-only view")
      .def_property_readonly("format", [](const Mesh& s) { return s.info.format; })
      .def_property_readonly("unit", [](const Mesh& s) { return units::to_string(s.info.unit); })
      .def_property_readonly("unit_guessed", [](const Mesh& s) { return s.info.unit_was_guessed; })
      .def_property_readonly("landmarks", [](const Mesh& s) {
        py::dict d;
        for (const auto& lm : s.info.landmarks) {
          py::array_t<double> pts({static_cast<py::ssize_t>(lm.points.size()), py::ssize_t{3}});
          auto p = pts.mutable_unchecked<2>();
          for (size_t i = 0; i < lm.points.size(); ++i)
            for (int k = 0; k < 3; ++k) p(i, k) = lm.points[i][k];
          d[py::str(lm.name)] = pts;
        }
        return d;
      }, "landmarks stored in the file (AAOP) [m]: {name: (n, 3) array}")
      .def("check", [](const Mesh& s) { return from_json(check_json(s)); },
           "The report of `socketsmith check mesh --json`: units, size, closed, manifold, orientation, components.")
      .def("__repr__", [](const Mesh& s) {
        return "<socketsmith.Mesh " + s.file + ": " + std::to_string(s.mesh.num_vertices()) + " vertices, " +
               std::to_string(s.mesh.num_triangles()) + " triangles>";
      });
  m.def("read_mesh", &read_mesh, py::arg("path"), py::arg("units") = py::none(),
        "Reads a surface (STL/OBJ/PLY/AOP by extension); units 'mm' | 'm' | None (guessed from its size).");
  m.def("check_mesh", [](const std::string& path, const std::optional<std::string>& unit, bool require_closed) {
        const auto mesh = read_mesh(path, unit);
        py::object j = from_json(check_json(*mesh));
        if (require_closed) geometry::require_closed_surface(mesh->mesh, "'" + path + "'");
        return j;
      }, py::arg("path"), py::arg("units") = py::none(), py::arg("require_closed") = false,
      "`socketsmith check mesh PATH --json` as a dict; require_closed raises TopologyError unless closed and manifold.");

  // Cases.
  m.def("demo_case", [](int target_nodes) { return from_json(design::case_to_json(pipeline::demo_case(target_nodes))); },
        py::arg("target_nodes") = 8000,
        "The embedded sample's case (generated transtibial limb, 70 kg, E = 100 kPa, PTB brim) as a dict.");
  m.def("normalise_case", [](const py::object& c, const std::optional<std::string>& folder) {
        return from_json(design::case_to_json(to_case(c, folder)));
      }, py::arg("case"), py::arg("folder") = py::none(),
      "Checks a case (dict or path) as the CLI does and returns it with every default filled in.");

  // The stump (stage 1).
  py::class_<Stump, std::shared_ptr<Stump>>(m, "Stump", "The meshed stump model of a case (pipeline::prepare_design).")
      .def_property_readonly("node_positions", [](py::object self) {
        return view_vec3(self.cast<Stump&>().setup->mesh.mesh.nodes, self); }, "(N, 3) rest node positions [m]")
      .def_property_readonly("hexahedra", [](py::object self) {
        return view_int_rows(self.cast<Stump&>().setup->mesh.mesh.hexahedra, self); }, "(E, 8) node ids (VTK order)")
      .def_property_readonly("node_tags", [](py::object self) {
        const auto& v = self.cast<Stump&>().setup->mesh.mesh.node_tags;
        return readonly(py::array_t<std::uint8_t>({static_cast<py::ssize_t>(v.size())}, {py::ssize_t{1}}, v.data(), self));
      }, "(N,) uint8 bit flags: 1 fixed, 2 surface, 4 bone, 8 proximal")
      .def_property_readonly("skin_nodes", [](py::object self) {
        return view_ints(self.cast<Stump&>().setup->solver->skin().nodes, self); }, "(S,) node ids of the skin, in skin order")
      .def_property_readonly("skin_areas_m2", [](py::object self) {
        return view_doubles(self.cast<Stump&>().setup->solver->skin().area_m2, self); })
      .def_property_readonly("thresholds_pa", [](py::object self) {
        return view_doubles(self.cast<Stump&>().setup->thresholds, self); }, "(S,) pain threshold per skin node [Pa]")
      .def_property_readonly("length_m", [](const Stump& s) { return s.setup->model.length_m; })
      .def_property_readonly("landmarks", [](const Stump& s) {
        py::dict d;
        for (const auto& l : s.setup->model.landmarks) {
          py::array_t<double> p(3);
          for (int k = 0; k < 3; ++k) p.mutable_at(k) = l.position[k];
          d[py::str(l.code)] = p;
        }
        return d;
      }, "{code: position [m]}")
      .def_property_readonly("case", [](const Stump& s) { return from_json(design::case_to_json(s.setup->case_file)); })
      .def("__repr__", [](const Stump& s) {
        return "<socketsmith.Stump " + s.setup->limb_label + ": " + std::to_string(s.setup->mesh.mesh.num_nodes()) + " nodes>";
      });
  m.def("prepare", &prepare, py::arg("case"), py::arg("target_nodes") = py::none(), py::arg("progress") = py::none(),
        py::arg("folder") = py::none(),
        "Reads (or generates) the case's limb, checks the case against it and meshes the stump (the design's expensive set-up).");

  // Designs (stage 2, and the whole run).
  py::class_<Design, std::shared_ptr<Design>>(m, "Design", "A solved design (pipeline::DesignResult) on its stump.")
      .def_property_readonly("stump", [](const Design& d) { return d.stump; })
      .def_property_readonly("radar", [](const Design& d) { return radar_array(d.result.state.radar); },
                             "[Fx, Fy, Fz (N), Tx, Ty, Tz (N m), stability (N)], as design.json's radar")
      .def_property_readonly("constraints_met", [](const Design& d) { return d.result.constraints_met; })
      .def_property_readonly("failing", [](const Design& d) { return d.result.state.status.failing(); })
      .def_property_readonly("optimised", [](const Design& d) { return d.result.optimised; })
      .def_property_readonly("message", [](const Design& d) {
        return d.result.optimised ? d.result.optimiser.message : d.result.state.message; })
      .def_property_readonly("max_pressure_ratio", [](const Design& d) { return d.result.state.max_requested_ratio; })
      .def_property_readonly("pressure_pa", [](py::object self) {
        return view_doubles(self.cast<Design&>().result.state.pressure_pa, self); }, "(S,) applied pressure per skin node [Pa]")
      .def_property_readonly("requested_pa", [](py::object self) {
        return view_doubles(self.cast<Design&>().result.state.requested_pa, self); }, "(S,) the spots' field before saturation [Pa]")
      .def_property_readonly("displacement_m", [](py::object self) {
        return view_doubles(self.cast<Design&>().result.state.displacement_m, self); })
      .def_property_readonly("skin_positions", [](py::object self) {
        return view_vec3(self.cast<Design&>().result.state.skin_positions, self); }, "(S, 3) deformed skin [m]")
      .def_property_readonly("rest_skin_positions", [](py::object self) {
        return view_vec3(self.cast<Design&>().result.rest_skin.vertices, self); }, "(S, 3) skin at rest [m]")
      .def_property_readonly("skin_triangles", [](py::object self) {
        return view_int_rows(self.cast<Design&>().result.rest_skin.triangles, self); }, "(T, 3) skin triangles (skin-local ids)")
      .def_property_readonly("node_positions", [](py::object self) {
        return view_xyz(self.cast<Design&>().result.state.positions, self); }, "(N, 3) deformed nodes [m]")
      .def_property_readonly("spots", [](const Design& d) {
        nlohmann::json j = nlohmann::json::array();
        for (const auto& s : d.result.spots) j.push_back(design::spot_to_json(s));
        return from_json(j);
      }, "the final spots in case-file units")
      .def_property_readonly("socket_vertices", [](py::object self) -> py::object {
        const auto& r = self.cast<Design&>().result;
        if (!r.socket) return py::none();
        return view_vec3(r.socket->solid.vertices, self);
      }, "(V, 3) the socket solid [m], None without a socket")
      .def_property_readonly("socket_triangles", [](py::object self) -> py::object {
        const auto& r = self.cast<Design&>().result;
        if (!r.socket) return py::none();
        return view_int_rows(r.socket->solid.triangles, self);
      })
      .def_property_readonly("cavity_volume_m3", [](const Design& d) -> py::object {
        if (!d.result.socket) return py::none();
        return py::float_(d.result.socket->cavity_volume_m3);
      })
      .def_property_readonly("summary", [](const Design& d) -> py::object {
        return d.summary.is_null() ? py::object(py::none()) : from_json(d.summary);
      }, "design.json as a dict (None until written: design(..., out=DIR) or write(DIR))")
      .def("write", [](Design& d, const std::string& out) {
        py::gil_scoped_release release;
        d.summary = pipeline::write_design_outputs(*d.stump->setup, d.result, out, 0.0);
      }, py::arg("out"), "Writes the files of `socketsmith design` (report, maps, socket.stl, design.json) into out.")
      .def("don", &don, py::arg("friction") = py::none(), py::arg("stand") = true, py::arg("step_mm") = py::none(),
           py::arg("steps") = 0, py::arg("progress") = py::none(),
           "Slides the designed socket onto the stump with Coulomb friction, then the standing load "
           "(`socketsmith simulate donning --case`).")
      .def("__repr__", [](const Design& d) {
        return std::string("<socketsmith.Design ") + (d.result.constraints_met ? "met" : "NOT met: " + d.result.state.status.failing()) + ">";
      });
  m.def("solve", &solve, py::arg("stump"), py::arg("optimise") = py::none(), py::arg("progress") = py::none(),
        "Optimises the stump's spots (or solves them as given) and builds the socket when every constraint holds.");
  m.def("design", &run_design, py::arg("case"), py::arg("out") = py::none(), py::arg("optimise") = py::none(),
        py::arg("target_nodes") = py::none(), py::arg("time_limit_s") = 0.0, py::arg("progress") = py::none(),
        py::arg("folder") = py::none(),
        "`socketsmith design CASE --out OUT` from a case dict (or path): with out, the same files and design.json "
        "(Design.summary); without, nothing is written.");

  py::class_<Donning, std::shared_ptr<Donning>>(m, "Donning", "contact::DonningResult of a designed socket.")
      .def_property_readonly("completed", [](const Donning& d) { return d.result.completed; })
      .def_property_readonly("stood", [](const Donning& d) { return d.result.stood; })
      .def_property_readonly("message", [](const Donning& d) { return d.result.message; })
      .def_property_readonly("steps", [](const Donning& d) { return d.result.steps; })
      .def_property_readonly("seconds", [](const Donning& d) { return d.result.seconds; })
      .def_property_readonly("force_on_socket_n", [](const Donning& d) {
        py::array_t<double> a(3);
        for (int k = 0; k < 3; ++k) a.mutable_at(k) = d.result.force_on_socket_n[k];
        return a;
      })
      .def_property_readonly("nodes", [](py::object self) { return view_ints(self.cast<Donning&>().result.nodes, self); },
                             "(S,) the candidate (skin) node ids")
      .def_property_readonly("pressure_pa", [](py::object self) {
        return view_doubles(self.cast<Donning&>().pressure_pa, self); }, "(S,) contact pressure per candidate node [Pa]")
      .def_property_readonly("node_positions", [](py::object self) {
        return view_xyz(self.cast<Donning&>().result.positions, self); }, "(N, 3) node positions at the end [m]")
      .def_property_readonly("series", [](const Donning& d) {
        py::list rows;
        for (const auto& s : d.result.series)
          rows.append(py::dict(py::arg("offset_mm") = s.offset_m * 1e3, py::arg("axial_force_n") = s.axial_force_n,
                               py::arg("contact_nodes") = s.contact_nodes, py::arg("sliding_nodes") = s.sliding_nodes,
                               py::arg("max_pressure_kpa") = s.max_pressure_pa / 1e3));
        return rows;
      }, "one dict per converged step");

  // CalculiX validation (`socketsmith validate design` / `validate donning`).
  py::class_<Validation, std::shared_ptr<Validation>> validation(m, "Validation",
      "A design checked in CalculiX (pipeline::validate_design): the comparison per skin node and summarised.");
  validation.def_property_readonly("summary", [](const Validation& v) { return from_json(v.run.summary); },
                             "summary.json as a dict: means, MAE, SD, RMSE, bias, R, p95, p99 per region and path (kPa or mm)")
      .def_property_readonly("converged", [](const Validation& v) { return v.run.check.converged; },
                             "False: ccx stopped early and its last converged increment was compared")
      .def_property_readonly("message", [](const Validation& v) { return v.run.check.message; })
      .def_property_readonly("mode", [](const Validation& v) { return calculix::to_string(v.run.check.mode); })
      .def_property_readonly("unit", [](const Validation& v) {
        return v.run.check.mode == calculix::DesignCheckMode::Load ? "m" : "Pa"; },
        "the unit of socketsmith_values / calculix_values: 'Pa' (contact pressure) or 'm' (displacement magnitude)")
      .def_property_readonly("design", [](const Validation& v) { return v.design; }, "the Design that was checked")
      .def_property_readonly("donning", [](const Validation& v) -> py::object {
        return v.donning ? py::cast(v.donning) : py::object(py::none()); },
        "socketsmith's own Donning (against_donning or stand), else None")
      .def_property_readonly("skin_nodes", [](py::object self) {
        return view_ints(self.cast<Validation&>().run.stump.skin->nodes, self); }, "(S,) the skin's node ids (the fields' order)")
      .def_property_readonly("rings_from_brim", [](py::object self) {
        return view_ints(self.cast<Validation&>().run.check.brim_ring, self); },
        "(S,) rings of quads from the brim: 0 above it, >= 1 socket nodes (the summary's 'all')")
      .def_property_readonly("calculix_displacement_m", [](py::object self) {
        return view_vec3(self.cast<Validation&>().run.check.fe_displacement_m, self); }, "(N, 3) CalculiX's node displacements [m]")
      .def_property_readonly("paths", [](py::object self) {
        py::dict d;
        for (const auto& pc : self.cast<Validation&>().run.check.paths)
          d[py::str(pc.name)] = py::dict(py::arg("label") = pc.label, py::arg("skin_index") = view_ints(pc.skin_index, self),
                                         py::arg("s") = view_doubles(pc.s, self), py::arg("vertical") = pc.is_vertical);
        return d;
      }, "{front|back|mid: {label, skin_index (skin nodes along it), s (mm up, or degrees round), vertical}}")
      .def("__repr__", [](const Validation& v) {
        return "<socketsmith.Validation " + calculix::to_string(v.run.check.mode) + (v.run.check.converged ? "" : " PARTIAL") +
               ": R " + std::to_string(v.run.check.all.r) + ">";
      });
  // The per-skin-node fields of calculix::DesignCheckResult, as read-only views.
  struct CheckField {
    const char* name;
    std::vector<double> calculix::DesignCheckResult::*field;
    const char* doc;
  };
  for (const CheckField& f : {
           CheckField{"socketsmith_values", &calculix::DesignCheckResult::socketsmith_value,
                      "(S,) socketsmith's field per skin node: designed (or donned) pressure [Pa], or displacement [m] in load mode"},
           CheckField{"calculix_values", &calculix::DesignCheckResult::fe_value,
                      "(S,) CalculiX's, the same quantity"},
           CheckField{"socketsmith_values_one_ring", &calculix::DesignCheckResult::socketsmith_value_smoothed,
                      "(S,) socketsmith_values averaged over each node's one ring (area-weighted)"},
           CheckField{"calculix_values_one_ring", &calculix::DesignCheckResult::fe_value_smoothed,
                      "(S,) calculix_values averaged over each node's one ring"},
           CheckField{"penetration_m", &calculix::DesignCheckResult::fe_penetration_m,
                      "(S,) CalculiX's penetration [m] (contact)"},
           CheckField{"calculix_force_pa", &calculix::DesignCheckResult::fe_force_pressure_pa,
                      "(S,) nodal force over nodal area [Pa] (empty in load mode)"},
           CheckField{"calculix_stress_pa", &calculix::DesignCheckResult::fe_stress_pressure_pa,
                      "(S,) -n.sigma.n [Pa] (empty in load mode)"},
           CheckField{"calculix_cpress_pa", &calculix::DesignCheckResult::fe_cpress_pa,
                      "(S,) nodal CPRESS [Pa] (empty in load mode)"}}) {
    validation.def_property_readonly(f.name, [field = f.field](py::object self) {
      return view_doubles(self.cast<Validation&>().run.check.*field, self); }, f.doc);
  }
  m.def("validate", [](const py::object& case_obj, const std::string& out, const std::string& mode, bool against_donning,
                       bool stand, bool nonlinear_body, std::optional<bool> optimise, std::optional<double> poisson,
                       bool neo_hookean, bool small_strain, const std::string& element, const std::string& fe_pressure,
                       std::optional<double> penalty, double stick_slope, std::optional<double> friction, double clearance_mm,
                       double travel_mm, double initial_increment, const std::string& ccx, int ccx_threads,
                       double ccx_time_limit_s, std::optional<int> target_nodes, const py::object& progress,
                       const std::optional<std::string>& folder) {
        ValidateArgs a;
        a.mode = mode;
        a.against_donning = against_donning;
        a.stand = stand;
        a.nonlinear_body = nonlinear_body;
        a.optimise = optimise;
        a.poisson = poisson;
        a.neo_hookean = neo_hookean;
        a.small_strain = small_strain;
        a.element = element;
        a.fe_pressure = fe_pressure;
        a.penalty = penalty;
        a.stick_slope = stick_slope;
        a.friction = friction;
        a.clearance_mm = clearance_mm;
        a.travel_mm = travel_mm;
        a.initial_increment = initial_increment;
        a.ccx = ccx;
        a.ccx_threads = ccx_threads;
        a.ccx_time_limit_s = ccx_time_limit_s;
        a.target_nodes = target_nodes;
        return validate(case_obj, out, a, progress, folder);
      },
      py::arg("case"), py::arg("out"), py::kw_only(), py::arg("mode") = "contact", py::arg("against_donning") = false,
      py::arg("stand") = false, py::arg("nonlinear_body") = false, py::arg("optimise") = py::none(),
      py::arg("poisson") = py::none(), py::arg("neo_hookean") = false, py::arg("small_strain") = false,
      py::arg("element") = "", py::arg("fe_pressure") = "force", py::arg("penalty") = py::none(),
      py::arg("stick_slope") = 5e7, py::arg("friction") = py::none(), py::arg("clearance_mm") = 1.0,
      py::arg("travel_mm") = 60.0, py::arg("initial_increment") = 0.05, py::arg("ccx") = "ccx",
      py::arg("ccx_threads") = 1, py::arg("ccx_time_limit_s") = 3600.0, py::arg("target_nodes") = py::none(),
      py::arg("progress") = py::none(), py::arg("folder") = py::none(),
      "`socketsmith validate design CASE --out OUT` (with against_donning=True and mode='donning': `validate donning`): "
      "designs the case, checks it in CalculiX and writes the comparison into out; the metrics as Validation.summary, "
      "the fields as NumPy views.");
}
