#pragma once
// The one place that changes GL pipeline state and object bindings. It skips unchanged values and
// can be resynchronised after third-party GL code (ImGui) with invalidate().
//
// Bindings live here, beside the render state, rather than in a second cache: a pass changes
// both, foreign code disturbs both, and one invalidate() and one call counter cover both. What is
// tracked: the draw framebuffer and the viewport, the program, the vertex array, the textures of
// units [0, kTextureUnits), the uniform and shader-storage buffers of binding points
// [0, kBufferBindings), and the draw-indirect buffer. Everything else is bound by objects' names
// (DSA) and needs no binding. Every binding starts unknown: the first call always reaches GL.
//
// Deleted objects: GL reuses a deleted name at once (Mesa does), so a cache still holding a
// deleted vertex array as bound would skip binding the new one of the same name. Every
// gfx::Handle of a bindable kind tells all live caches of its thread when it deletes its object,
// and they forget any binding of that name (it becomes unknown, so the next bind reaches GL).
// Objects must therefore be deleted through handles, which the project does everywhere.
#include <array>
#include <cstddef>
#include <optional>

#include "gfx/handles.hpp"
#include "gfx/pipeline_state.hpp"

namespace gis::gfx {

class Program;

/// A rectangle of the draw framebuffer in pixels (glViewport).
struct Viewport {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
  bool operator==(const Viewport&) const = default;
};

/// A draw framebuffer (0 = the default framebuffer) with the viewport into it.
struct DrawTarget {
  GLuint framebuffer = 0;
  Viewport viewport;
  bool operator==(const DrawTarget&) const = default;
};

class StateCache {
 public:
  static constexpr GLuint kTextureUnits = 16;
  static constexpr GLuint kBufferBindings = 16;

  StateCache();
  ~StateCache();
  // Registered by address with the handles' deletion notice: neither copied nor moved.
  StateCache(const StateCache&) = delete;
  StateCache& operator=(const StateCache&) = delete;

  /// Makes GL's state equal to `state`, issuing calls only for what differs from the cached
  /// state (all of it after invalidate()).
  void apply(const PipelineState& state);

  /// Forget what GL holds, state and bindings: the next call for each sets it. Call after foreign
  /// GL code.
  void invalidate();

  /// Enables every write mask (colour, depth, both stencil faces) so that a clear clears all,
  /// keeping the cache in step. Used by RenderPass before glClear*.
  void prepareForClear();

  // Bindings; each issues its GL call only when the binding differs from the cached one.
  /// Binds the draw framebuffer (0 = the default framebuffer) with a viewport covering
  /// width × height. The read framebuffer is not tracked (readbacks bind it themselves).
  void bindDrawTarget(GLuint framebuffer, int width, int height) {
    bindDrawTarget(DrawTarget{framebuffer, Viewport{0, 0, width, height}});
  }
  void bindDrawTarget(const DrawTarget& target);
  /// The bound draw framebuffer and viewport; what the cache does not know (after invalidate())
  /// is read back from GL once and kept.
  [[nodiscard]] DrawTarget drawTarget();
  void useProgram(GLuint program);
  void useProgram(const Program& program);
  void bindVertexArray(GLuint vertexArray);
  /// glBindTextureUnit: `texture` to its own target on `unit` (0 unbinds every target there).
  void bindTexture(GLuint unit, GLuint texture);
  /// glBindBufferBase on GL_UNIFORM_BUFFER / GL_SHADER_STORAGE_BUFFER binding point `index`.
  void bindUniformBuffer(GLuint index, GLuint buffer);
  void bindStorageBuffer(GLuint index, GLuint buffer);
  /// The buffer glDrawElementsIndirect and friends read their commands from.
  void bindIndirectBuffer(GLuint buffer);

  /// The state GL actually holds, read with glGet* (for tests: no state leaks between passes).
  [[nodiscard]] static PipelineState queryGl();

  /// Number of GL state and binding calls issued so far (to show that redundant calls are
  /// skipped).
  [[nodiscard]] std::size_t glCallCount() const { return calls_; }

  [[nodiscard]] const PipelineState& cached() const { return current_; }

 private:
  friend void detail::forgetBindings(BindableKind kind, GLuint id);

  void applyDepth(const DepthState& s, bool force);
  void applyStencil(const StencilState& s, bool force);
  void applyBlend(const BlendState& s, bool force);
  void applyRaster(const RasterState& s, bool force);
  /// Every binding of `id` as an object of `kind` becomes unknown (the object was deleted).
  void forget(BindableKind kind, GLuint id);
  void bindBuffer(GLenum target, std::array<std::optional<GLuint>, kBufferBindings>& slots, GLuint index,
                  GLuint buffer);

  PipelineState current_{};
  bool valid_ = false;
  std::size_t calls_ = 0;

  // Unknown (nullopt) until set through the cache, and again after invalidate() or the deletion
  // of the object named.
  std::optional<GLuint> drawFramebuffer_;
  std::optional<Viewport> viewport_;
  std::optional<GLuint> program_;
  std::optional<GLuint> vertexArray_;
  std::array<std::optional<GLuint>, kTextureUnits> textures_{};
  std::array<std::optional<GLuint>, kBufferBindings> uniformBuffers_{};
  std::array<std::optional<GLuint>, kBufferBindings> storageBuffers_{};
  std::optional<GLuint> indirectBuffer_;

  // The live caches of this thread (its current context), for the handles' deletion notice.
  StateCache* previousLive_ = nullptr;
  StateCache* nextLive_ = nullptr;
};

}  // namespace gis::gfx
