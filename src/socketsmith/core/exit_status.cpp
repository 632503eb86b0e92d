#include "socketsmith/core/exit_status.h"

#include <filesystem>
#include <ios>
#include <new>

#include <nlohmann/json.hpp>

#include "socketsmith/core/errors.h"

namespace socketsmith {

std::string one_line(std::string_view text) {
  // Lines trimmed, empty ones dropped, joined with "; ".
  std::string out;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(start, end - start);
    while (!line.empty() && (line.back() == ' ' || line.back() == '\t' || line.back() == '\r')) line.remove_suffix(1);
    while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
    if (!line.empty()) {
      if (!out.empty()) out += "; ";
      out += line;
    }
    start = end + 1;
  }
  return out;
}

std::string ExitStatus::line() const {
  if (code == kExitInternal) return "internal error: " + message + " (please report it)";
  return "error: " + message;
}

ExitStatus exit_status(std::exception_ptr error) {
  if (!error) return {kExitSuccess, {}};
  try {
    std::rethrow_exception(error);
  } catch (const InvalidInputError& e) {
    return {kExitBadInput, one_line(e.what())};
  } catch (const IoError& e) {
    return {kExitFileError, one_line(e.what())};
  } catch (const SolverError& e) {
    return {kExitSolverDiverged, one_line(e.what())};
  } catch (const TopologyError& e) {
    return {kExitBadTopology, one_line(e.what())};
  } catch (const Error& e) {  // an internal invariant (SOCKETSMITH_ASSERT)
    return {kExitInternal, one_line(e.what())};
  } catch (const nlohmann::json::exception& e) {
    // JSON read at run time is the user's (case files, scripts, rigs, models): a value of the
    // wrong type or a document that is not JSON is bad input.
    return {kExitBadInput, one_line(std::string("a JSON input is not what was expected: ") + e.what())};
  } catch (const std::filesystem::filesystem_error& e) {
    return {kExitFileError, one_line(e.what())};
  } catch (const std::ios_base::failure& e) {
    return {kExitFileError, one_line(std::string("file error: ") + e.what())};
  } catch (const std::bad_alloc&) {
    return {kExitInternal, "out of memory (an input far larger than a limb model, or a bug)"};
  } catch (const std::exception& e) {
    return {kExitInternal, one_line(e.what())};
  } catch (...) {
    return {kExitInternal, "an exception of unknown type"};
  }
}

}  // namespace socketsmith
