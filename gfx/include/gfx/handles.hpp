#pragma once
// Move-only owners of GL object names. No copyable struct in this project owns a GLuint.
#include <utility>

#include "gfx/gl.hpp"

namespace gis::gfx {

/// Owns one GL object name; `Deleter::destroy(GLuint)` releases it. Move-only.
template <typename Deleter>
class Handle {
 public:
  Handle() = default;
  explicit Handle(GLuint id) : id_(id) {}
  ~Handle() { reset(); }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, 0)) {}
  Handle& operator=(Handle&& other) noexcept {
    if (this != &other) {
      reset();
      id_ = std::exchange(other.id_, 0);
    }
    return *this;
  }

  [[nodiscard]] GLuint id() const { return id_; }
  explicit operator bool() const { return id_ != 0; }
  void reset() {
    if (id_ != 0) Deleter::destroy(id_);
    id_ = 0;
  }

 private:
  GLuint id_ = 0;
};

/// The kinds of object a StateCache binds, and so must forget when one is deleted.
enum class BindableKind { Buffer, VertexArray, Texture, Framebuffer, Program };

namespace detail {
/// Tells every live StateCache of this thread that object `id` of `kind` is being deleted: GL may
/// hand its name to the next object created, which a cache still holding it as bound would then
/// fail to bind (state_cache.hpp).
void forgetBindings(BindableKind kind, GLuint id);

struct BufferDeleter {
  static void destroy(GLuint id) {
    forgetBindings(BindableKind::Buffer, id);
    glDeleteBuffers(1, &id);
  }
};
struct VertexArrayDeleter {
  static void destroy(GLuint id) {
    forgetBindings(BindableKind::VertexArray, id);
    glDeleteVertexArrays(1, &id);
  }
};
struct TextureDeleter {
  static void destroy(GLuint id) {
    forgetBindings(BindableKind::Texture, id);
    glDeleteTextures(1, &id);
  }
};
struct RenderbufferDeleter {
  static void destroy(GLuint id) { glDeleteRenderbuffers(1, &id); }
};
struct FramebufferDeleter {
  static void destroy(GLuint id) {
    forgetBindings(BindableKind::Framebuffer, id);
    glDeleteFramebuffers(1, &id);
  }
};
struct ProgramDeleter {
  static void destroy(GLuint id) {
    forgetBindings(BindableKind::Program, id);
    glDeleteProgram(id);
  }
};
struct ShaderDeleter {
  static void destroy(GLuint id) { glDeleteShader(id); }
};
struct QueryDeleter {
  static void destroy(GLuint id) { glDeleteQueries(1, &id); }
};
}  // namespace detail

using BufferHandle = Handle<detail::BufferDeleter>;
using VertexArrayHandle = Handle<detail::VertexArrayDeleter>;
using TextureHandle = Handle<detail::TextureDeleter>;
using RenderbufferHandle = Handle<detail::RenderbufferDeleter>;
using FramebufferHandle = Handle<detail::FramebufferDeleter>;
using ProgramHandle = Handle<detail::ProgramDeleter>;
using ShaderHandle = Handle<detail::ShaderDeleter>;
using QueryHandle = Handle<detail::QueryDeleter>;

// Creation through DSA (GL 4.5): the objects exist, not just their names.
BufferHandle createBuffer();
VertexArrayHandle createVertexArray();
TextureHandle createTexture(GLenum target);
RenderbufferHandle createRenderbuffer();
FramebufferHandle createFramebuffer();
QueryHandle createQuery(GLenum target);

/// An immutable buffer holding `bytes` bytes of `data` (glNamedBufferStorage).
BufferHandle createBufferWithData(const void* data, std::size_t bytes, GLbitfield flags = 0);

}  // namespace gis::gfx
