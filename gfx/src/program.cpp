#include "gfx/program.hpp"

#include <algorithm>

#include <glm/gtc/type_ptr.hpp>

#include "shaders/embedded.hpp"

namespace gis::gfx {
namespace {

std::optional<GLenum> stageFromFileName(std::string_view file) {
  auto ends = [&](std::string_view ext) {
    return file.size() >= ext.size() && file.substr(file.size() - ext.size()) == ext;
  };
  if (ends(".vert")) return GL_VERTEX_SHADER;
  if (ends(".frag")) return GL_FRAGMENT_SHADER;
  if (ends(".geom")) return GL_GEOMETRY_SHADER;
  if (ends(".comp")) return GL_COMPUTE_SHADER;
  return std::nullopt;
}

/// Inserts the defines after the #version line (which must stay first).
std::string withDefines(std::string_view text, const std::vector<std::string>& defines) {
  std::string out(text);
  if (defines.empty()) return out;
  std::string block;
  for (const std::string& d : defines) block += "#define " + d + "\n";
  const std::size_t versionPos = out.find("#version");
  const std::size_t lineEnd = versionPos == std::string::npos ? std::string::npos : out.find('\n', versionPos);
  if (lineEnd == std::string::npos) return block + out;
  out.insert(lineEnd + 1, block);
  return out;
}

std::string shaderLog(GLuint shader) {
  GLint length = 0;
  glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
  glGetShaderInfoLog(shader, length, nullptr, log.data());
  return log;
}

std::string programLog(GLuint program) {
  GLint length = 0;
  glGetProgramiv(program, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
  glGetProgramInfoLog(program, length, nullptr, log.data());
  return log;
}

Diagnostic shaderError(const std::string& file, const std::string& message) {
  return Diagnostic{Severity::Error, file, "", "", message};
}

}  // namespace

Result<Program> Program::fromSources(const std::vector<std::pair<GLenum, std::string>>& sources,
                                     const std::string& name) {
  Program program;
  program.handle_ = ProgramHandle(glCreateProgram());
  std::vector<ShaderHandle> shaders;
  for (const auto& [type, text] : sources) {
    ShaderHandle shader(glCreateShader(type));
    const char* ptr = text.c_str();
    glShaderSource(shader.id(), 1, &ptr, nullptr);
    glCompileShader(shader.id());
    GLint ok = GL_FALSE;
    glGetShaderiv(shader.id(), GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE) return Result<Program>::failure(shaderError(name, "compile failed:\n" + shaderLog(shader.id())));
    glAttachShader(program.handle_.id(), shader.id());
    shaders.push_back(std::move(shader));
  }
  glLinkProgram(program.handle_.id());
  GLint linked = GL_FALSE;
  glGetProgramiv(program.handle_.id(), GL_LINK_STATUS, &linked);
  for (const ShaderHandle& s : shaders) glDetachShader(program.handle_.id(), s.id());
  if (linked != GL_TRUE) {
    return Result<Program>::failure(shaderError(name, "link failed:\n" + programLog(program.handle_.id())));
  }
  Result<Program> result;
  result.value = std::move(program);
  return result;
}

Result<Program> Program::build(const std::vector<ShaderStage>& stages) {
  std::vector<std::pair<GLenum, std::string>> sources;
  std::string name;
  for (const ShaderStage& stage : stages) {
    name += (name.empty() ? "" : "+") + stage.file;
    const std::optional<GLenum> type = stageFromFileName(stage.file);
    if (!type) return Result<Program>::failure(shaderError(stage.file, "unknown shader stage (extension)"));
    const std::optional<std::string_view> text = shaders::source(stage.file);
    if (!text) return Result<Program>::failure(shaderError(stage.file, "no such embedded shader"));
    sources.emplace_back(*type, withDefines(*text, stage.defines));
  }
  return fromSources(sources, name);
}

GLint Program::location(std::string_view name) {
  const std::string key(name);
  auto it = locations_.find(key);
  if (it != locations_.end()) return it->second;
  const GLint loc = glGetUniformLocation(handle_.id(), key.c_str());
  locations_.emplace(key, loc);
  return loc;
}

void Program::set(std::string_view name, float v) { glProgramUniform1f(id(), location(name), v); }
void Program::set(std::string_view name, int v) { glProgramUniform1i(id(), location(name), v); }
void Program::set(std::string_view name, const glm::vec2& v) {
  glProgramUniform2fv(id(), location(name), 1, glm::value_ptr(v));
}
void Program::set(std::string_view name, const glm::vec3& v) {
  glProgramUniform3fv(id(), location(name), 1, glm::value_ptr(v));
}
void Program::set(std::string_view name, const glm::vec4& v) {
  glProgramUniform4fv(id(), location(name), 1, glm::value_ptr(v));
}
void Program::set(std::string_view name, const glm::mat4& m) {
  glProgramUniformMatrix4fv(id(), location(name), 1, GL_FALSE, glm::value_ptr(m));
}

}  // namespace gis::gfx
