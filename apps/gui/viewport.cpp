#include "viewport.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::gui {

// ------------------------------------------------------------------------------------------------
// Camera
// ------------------------------------------------------------------------------------------------

Vec3 OrbitCamera::eye() const {
  const Vec3 side = up.cross(front).normalized();
  const Vec3 horizontal = std::cos(yaw_rad) * front + std::sin(yaw_rad) * side;
  return target + distance_m * (std::cos(pitch_rad) * horizontal + std::sin(pitch_rad) * up);
}

Eigen::Matrix4f OrbitCamera::view() const {
  const Vec3 e = eye();
  const Vec3 f = (target - e).normalized();
  Vec3 s = f.cross(up);
  if (s.norm() < 1e-9) s = f.cross(front);
  s.normalize();
  const Vec3 u = s.cross(f);
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.block<1, 3>(0, 0) = s.cast<float>().transpose();
  m.block<1, 3>(1, 0) = u.cast<float>().transpose();
  m.block<1, 3>(2, 0) = -f.cast<float>().transpose();
  m(0, 3) = static_cast<float>(-s.dot(e));
  m(1, 3) = static_cast<float>(-u.dot(e));
  m(2, 3) = static_cast<float>(f.dot(e));
  return m;
}

Eigen::Matrix4f OrbitCamera::projection(double aspect) const {
  const double n = std::max(1e-4, 0.02 * distance_m), fa = 20.0 * distance_m + 1.0;
  const double t = 1.0 / std::tan(0.5 * fov_y_rad);
  Eigen::Matrix4f p = Eigen::Matrix4f::Zero();
  p(0, 0) = static_cast<float>(t / aspect);
  p(1, 1) = static_cast<float>(t);
  p(2, 2) = static_cast<float>(-(fa + n) / (fa - n));
  p(2, 3) = static_cast<float>(-2 * fa * n / (fa - n));
  p(3, 2) = -1.0f;
  return p;
}

void OrbitCamera::frame(const geometry::Aabb& box) {
  if (box.is_empty()) return;
  target = box.center();
  const double r = 0.5 * box.extent().norm();
  distance_m = std::max(1e-3, 1.15 * r / std::sin(0.5 * fov_y_rad));
}

void OrbitCamera::orbit(double dx_px, double dy_px) {
  yaw_rad -= 0.008 * dx_px;
  pitch_rad = std::clamp(pitch_rad + 0.008 * dy_px, -1.5, 1.5);
}

void OrbitCamera::pan(double dx_px, double dy_px, double viewport_height_px) {
  const Vec3 e = eye();
  const Vec3 f = (target - e).normalized();
  const Vec3 s = f.cross(up).normalized();
  const Vec3 u = s.cross(f);
  const double m_per_px = 2.0 * distance_m * std::tan(0.5 * fov_y_rad) / std::max(1.0, viewport_height_px);
  target += m_per_px * (-dx_px * s + dy_px * u);
}

void OrbitCamera::zoom(double notches) { distance_m = std::clamp(distance_m * std::pow(0.88, notches), 1e-3, 100.0); }

std::pair<Vec3, Vec3> OrbitCamera::ray(double x_px, double y_px, double width_px, double height_px) const {
  const Vec3 e = eye();
  const Vec3 f = (target - e).normalized();
  const Vec3 s = f.cross(up).normalized();
  const Vec3 u = s.cross(f);
  const double t = std::tan(0.5 * fov_y_rad);
  const double aspect = width_px / std::max(1.0, height_px);
  const double nx = 2.0 * x_px / width_px - 1.0, ny = 1.0 - 2.0 * y_px / height_px;
  return {e, (f + nx * t * aspect * s + ny * t * u).normalized()};
}

std::optional<Eigen::Vector2d> OrbitCamera::project(const Vec3& p, double width_px, double height_px) const {
  const Eigen::Vector4f c = projection(width_px / std::max(1.0, height_px)) * view() *
                            Eigen::Vector4f(static_cast<float>(p.x()), static_cast<float>(p.y()),
                                            static_cast<float>(p.z()), 1.0f);
  if (c.w() <= 0) return std::nullopt;
  return Eigen::Vector2d((c.x() / c.w() + 1.0) * 0.5 * width_px, (1.0 - c.y() / c.w()) * 0.5 * height_px);
}

std::optional<RayHit> pick(const geometry::TriMesh& mesh, const Vec3& o, const Vec3& d) {
  // Möller–Trumbore over every triangle: a click is rare and the stump has < 100k triangles.
  std::optional<RayHit> best;
  for (int t = 0; t < mesh.num_triangles(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Vec3& a = mesh.vertices[tri[0]];
    const Vec3 e1 = mesh.vertices[tri[1]] - a, e2 = mesh.vertices[tri[2]] - a;
    const Vec3 p = d.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-18) continue;
    const double inv = 1.0 / det;
    const Vec3 s = o - a;
    const double u = s.dot(p) * inv;
    if (u < 0 || u > 1) continue;
    const Vec3 q = s.cross(e1);
    const double v = d.dot(q) * inv;
    if (v < 0 || u + v > 1) continue;
    const double dist = e2.dot(q) * inv;
    if (dist <= 0) continue;
    if (!best || dist < best->distance_m) best = RayHit{t, o + dist * d, dist};
  }
  return best;
}

// ------------------------------------------------------------------------------------------------
// GPU buffers
// ------------------------------------------------------------------------------------------------

GpuMesh::~GpuMesh() {
  if (vao_ == 0) return;
  const GLuint b[] = {vbo_pos_, vbo_nrm_, vbo_col_, ebo_};
  glDeleteBuffers(4, b);
  glDeleteVertexArrays(1, &vao_);
}

void GpuMesh::ensure_buffers() {
  if (vao_ != 0) return;
  glGenVertexArrays(1, &vao_);
  GLuint b[4];
  glGenBuffers(4, b);
  vbo_pos_ = b[0];
  vbo_nrm_ = b[1];
  vbo_col_ = b[2];
  ebo_ = b[3];
  glBindVertexArray(vao_);
  const GLuint vbos[] = {vbo_pos_, vbo_nrm_, vbo_col_};
  const int sizes[] = {3, 3, 4};
  for (GLuint k = 0; k < 3; ++k) {
    glBindBuffer(GL_ARRAY_BUFFER, vbos[k]);
    glEnableVertexAttribArray(k);
    glVertexAttribPointer(k, sizes[k], GL_FLOAT, GL_FALSE, 0, nullptr);
  }
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ebo_);
  glBindVertexArray(0);
}

void GpuMesh::set_geometry(const geometry::TriMesh& mesh) {
  ensure_buffers();
  std::vector<Vec3> normal(mesh.vertices.size(), Vec3::Zero());
  for (const auto& t : mesh.triangles) {
    const Vec3 n = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    for (int k : t) normal[k] += n;  // area-weighted
  }
  std::vector<float> pos, nrm;
  pos.reserve(3 * mesh.vertices.size());
  nrm.reserve(3 * mesh.vertices.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3 n = normal[i].norm() > 0 ? Vec3(normal[i].normalized()) : Vec3::UnitZ();
    for (int k = 0; k < 3; ++k) {
      pos.push_back(static_cast<float>(mesh.vertices[i][k]));
      nrm.push_back(static_cast<float>(n[k]));
    }
  }
  std::vector<unsigned> idx;
  idx.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (int k : t) idx.push_back(static_cast<unsigned>(k));
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_pos_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(pos.size() * sizeof(float)), pos.data(), GL_DYNAMIC_DRAW);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_nrm_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(nrm.size() * sizeof(float)), nrm.data(), GL_DYNAMIC_DRAW);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(idx.size() * sizeof(unsigned)), idx.data(),
               GL_STATIC_DRAW);
  glBindVertexArray(0);
  index_count_ = static_cast<int>(idx.size());
  if (vertex_count_ != mesh.num_vertices()) {
    vertex_count_ = mesh.num_vertices();
    set_colour({0.8f, 0.8f, 0.8f, 1.0f});
  }
}

void GpuMesh::set_colours(const std::vector<Rgba>& colours) {
  ensure_buffers();
  glBindBuffer(GL_ARRAY_BUFFER, vbo_col_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(colours.size() * sizeof(Rgba)), colours.data(),
               GL_DYNAMIC_DRAW);
}

void GpuMesh::set_colour(const Rgba& colour) {
  set_colours(std::vector<Rgba>(static_cast<size_t>(vertex_count_), colour));
}

void GpuMesh::draw() const {
  if (index_count_ == 0) return;
  glBindVertexArray(vao_);
  glDrawElements(GL_TRIANGLES, index_count_, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
}

GpuLines::~GpuLines() {
  if (vao_ == 0) return;
  glDeleteBuffers(1, &vbo_);
  glDeleteVertexArrays(1, &vao_);
}

void GpuLines::set_points(const std::vector<Vec3>& points, bool closed) {
  if (vao_ == 0) {
    glGenVertexArrays(1, &vao_);
    glGenBuffers(1, &vbo_);
    glBindVertexArray(vao_);
    glBindBuffer(GL_ARRAY_BUFFER, vbo_);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    glDisableVertexAttribArray(1);
    glDisableVertexAttribArray(2);
    glBindVertexArray(0);
  }
  std::vector<float> p;
  for (const auto& v : points)
    for (int k = 0; k < 3; ++k) p.push_back(static_cast<float>(v[k]));
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(p.size() * sizeof(float)), p.data(), GL_DYNAMIC_DRAW);
  count_ = static_cast<int>(points.size());
  closed_ = closed;
}

void GpuLines::draw() const {
  if (count_ < 2) return;
  glBindVertexArray(vao_);
  glDrawArrays(closed_ ? GL_LINE_LOOP : GL_LINE_STRIP, 0, count_);
  glBindVertexArray(0);
}

// ------------------------------------------------------------------------------------------------
// Shader
// ------------------------------------------------------------------------------------------------

namespace {

constexpr const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_colour;
uniform mat4 u_mvp;
uniform mat4 u_view;
out vec3 v_normal;
out vec4 v_colour;
void main() {
  gl_Position = u_mvp * vec4(a_pos, 1.0);
  v_normal = mat3(u_view) * a_normal;
  v_colour = a_colour;
})";

constexpr const char* kFragmentShader = R"(#version 330 core
in vec3 v_normal;
in vec4 v_colour;
uniform float u_alpha;
uniform int u_lit;
uniform int u_use_colour;
uniform vec4 u_colour;
out vec4 frag;
void main() {
  vec4 c = u_use_colour == 1 ? u_colour : v_colour;
  if (u_lit == 1) {
    vec3 n = normalize(v_normal);
    float l = n.z;                       // headlight: the eye looks along -z
    float shade = l >= 0.0 ? 0.3 + 0.7 * l : 0.6 * (0.3 + 0.7 * -l);  // back faces darker
    c.rgb *= shade;
  }
  frag = vec4(c.rgb, c.a * u_alpha);
})";

GLuint compile(GLenum kind, const char* source) {
  const GLuint s = glCreateShader(kind);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[1024];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    fail<Error>("socketsmith-gui: shader compilation failed: {}", log);
  }
  return s;
}

}  // namespace

MeshRenderer::MeshRenderer() {
  const GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader), fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
  program_ = glCreateProgram();
  glAttachShader(program_, vs);
  glAttachShader(program_, fs);
  glLinkProgram(program_);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program_, GL_LINK_STATUS, &ok);
  if (!ok) fail<Error>("socketsmith-gui: shader program did not link (OpenGL 3.3 core needed)");
  loc_mvp_ = glGetUniformLocation(program_, "u_mvp");
  loc_view_ = glGetUniformLocation(program_, "u_view");
  loc_alpha_ = glGetUniformLocation(program_, "u_alpha");
  loc_lit_ = glGetUniformLocation(program_, "u_lit");
  loc_colour_ = glGetUniformLocation(program_, "u_colour");
  loc_use_colour_ = glGetUniformLocation(program_, "u_use_colour");
}

MeshRenderer::~MeshRenderer() { glDeleteProgram(program_); }

void MeshRenderer::begin(const OrbitCamera& camera, int width, int height) {
  glViewport(0, 0, width, height);
  glDisable(GL_SCISSOR_TEST);
  glClearColor(0.93f, 0.94f, 0.96f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);
  glUseProgram(program_);
  const Eigen::Matrix4f view = camera.view();
  const Eigen::Matrix4f mvp = camera.projection(static_cast<double>(width) / std::max(1, height)) * view;
  glUniformMatrix4fv(loc_mvp_, 1, GL_FALSE, mvp.data());
  glUniformMatrix4fv(loc_view_, 1, GL_FALSE, view.data());
  glUniform1f(loc_alpha_, 1.0f);
  glUniform1i(loc_lit_, 1);
  glUniform1i(loc_use_colour_, 0);
}

void MeshRenderer::draw_opaque(const GpuMesh& mesh) {
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glUniform1f(loc_alpha_, 1.0f);
  mesh.draw();
}

void MeshRenderer::draw_translucent(const GpuMesh& mesh, float alpha) {
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glDepthMask(GL_FALSE);
  glEnable(GL_CULL_FACE);  // the near wall only: one blended layer (cheaper in software, reads better)
  glCullFace(GL_BACK);
  glUniform1f(loc_alpha_, alpha);
  mesh.draw();
  glDisable(GL_CULL_FACE);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glUniform1f(loc_alpha_, 1.0f);
}

void MeshRenderer::draw_lines(const GpuLines& lines, const Rgba& colour, bool on_top) {
  if (on_top) glDisable(GL_DEPTH_TEST);
  glUniform1i(loc_lit_, 0);
  glUniform1i(loc_use_colour_, 1);
  glUniform4fv(loc_colour_, 1, colour.data());
  lines.draw();
  glUniform1i(loc_lit_, 1);
  glUniform1i(loc_use_colour_, 0);
  glEnable(GL_DEPTH_TEST);
}

void MeshRenderer::end() {
  glUseProgram(0);
  glDisable(GL_DEPTH_TEST);
}

SceneTarget::~SceneTarget() {
  if (fbo_ == 0) return;
  glDeleteFramebuffers(1, &fbo_);
  const GLuint rb[] = {colour_, depth_};
  glDeleteRenderbuffers(2, rb);
}

bool SceneTarget::resize(int width, int height, int samples) {
  if (fbo_ != 0 && width == width_ && height == height_ && samples == samples_) return false;
  if (fbo_ == 0) {
    glGenFramebuffers(1, &fbo_);
    GLuint rb[2];
    glGenRenderbuffers(2, rb);
    colour_ = rb[0];
    depth_ = rb[1];
  }
  width_ = width;
  height_ = height;
  samples_ = samples;
  glBindRenderbuffer(GL_RENDERBUFFER, colour_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples > 1 ? samples : 0, GL_RGBA8, width, height);
  glBindRenderbuffer(GL_RENDERBUFFER, depth_);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, samples > 1 ? samples : 0, GL_DEPTH_COMPONENT24, width, height);
  glBindRenderbuffer(GL_RENDERBUFFER, 0);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  if (status != GL_FRAMEBUFFER_COMPLETE)
    fail<Error>("socketsmith-gui: the offscreen framebuffer is incomplete (status 0x{:x})", status);
  return true;
}

void SceneTarget::bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
}

void SceneTarget::blit_to_window(int x, int y) const {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  glBlitFramebuffer(0, 0, width_, height_, x, y, x + width_, y + height_, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

std::vector<std::uint8_t> read_pixels(int width, int height) {
  std::vector<std::uint8_t> rgb(static_cast<size_t>(width) * height * 3);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
  // OpenGL's rows start at the bottom.
  std::vector<std::uint8_t> flipped(rgb.size());
  const size_t row = static_cast<size_t>(width) * 3;
  for (int y = 0; y < height; ++y)
    std::copy_n(rgb.data() + static_cast<size_t>(height - 1 - y) * row, row, flipped.data() + static_cast<size_t>(y) * row);
  return flipped;
}

}  // namespace socketsmith::gui
