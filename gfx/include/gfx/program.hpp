#pragma once
// GLSL programs built from the shader files embedded from shaders/ at build time.
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "core/diagnostics.hpp"
#include "gfx/handles.hpp"

namespace gis::gfx {

/// One stage: an embedded file name (e.g. "terrain.vert"; the stage comes from the extension
/// .vert/.frag/.geom/.comp) and #defines inserted after the #version line.
struct ShaderStage {
  std::string file;
  std::vector<std::string> defines;
};

class Program {
 public:
  Program() = default;
  /// Compiles and links; the log of a failing stage names the file. Needs a current context.
  static Result<Program> build(const std::vector<ShaderStage>& stages);
  /// From source text (tests): stage types given explicitly.
  static Result<Program> fromSources(const std::vector<std::pair<GLenum, std::string>>& sources,
                                     const std::string& name);

  /// Made current with StateCache::useProgram; uniforms are set by name (glProgramUniform*),
  /// current or not.
  [[nodiscard]] GLuint id() const { return handle_.id(); }

  /// Uniform location (cached; -1 when the uniform is not active).
  GLint location(std::string_view name);
  void set(std::string_view name, float v);
  void set(std::string_view name, int v);
  void set(std::string_view name, const glm::vec2& v);
  void set(std::string_view name, const glm::vec3& v);
  void set(std::string_view name, const glm::vec4& v);
  void set(std::string_view name, const glm::mat4& m);

 private:
  ProgramHandle handle_;
  std::unordered_map<std::string, GLint> locations_;
};

}  // namespace gis::gfx
