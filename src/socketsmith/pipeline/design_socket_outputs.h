#pragma once
/// The socket's files of a design (inside `pipeline` only, for `write_design_outputs`): socket.stl,
/// socket.vtp (the wall thickness per vertex, the face kinds), thickness_map.png, the report's
/// socket section and design.json's socket entry. Why apart from design_outputs.cpp: the socket and
/// its measurements are the one output a design without a socket does not have, and the largest.

#include <filesystem>

#include <nlohmann/json.hpp>

#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/report/design_report.h"

namespace socketsmith::pipeline {

/// socket.stl, socket.vtp and thickness_map.png (only for a valid design: never a socket that
/// violates the constraints), the report's socket section into @p rs; returns design.json's socket
/// entry (null without a socket).
nlohmann::json write_socket_outputs(const DesignSetup& setup, const DesignResult& result,
                                    const std::filesystem::path& out, const report::SurfaceFrame& sframe,
                                    report::ReportSocket& rs);

}  // namespace socketsmith::pipeline
