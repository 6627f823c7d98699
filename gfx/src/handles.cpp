#include "gfx/handles.hpp"

namespace gis::gfx {

BufferHandle createBuffer() {
  GLuint id = 0;
  glCreateBuffers(1, &id);
  return BufferHandle(id);
}

VertexArrayHandle createVertexArray() {
  GLuint id = 0;
  glCreateVertexArrays(1, &id);
  return VertexArrayHandle(id);
}

TextureHandle createTexture(GLenum target) {
  GLuint id = 0;
  glCreateTextures(target, 1, &id);
  return TextureHandle(id);
}

RenderbufferHandle createRenderbuffer() {
  GLuint id = 0;
  glCreateRenderbuffers(1, &id);
  return RenderbufferHandle(id);
}

FramebufferHandle createFramebuffer() {
  GLuint id = 0;
  glCreateFramebuffers(1, &id);
  return FramebufferHandle(id);
}

QueryHandle createQuery(GLenum /*target*/) {
  // glGenQueries, not glCreateQueries: Mesa 22's glCreateQueries rejects the
  // ARB_pipeline_statistics_query targets that glBeginQuery accepts. The object comes to life
  // at its first glBeginQuery.
  GLuint id = 0;
  glGenQueries(1, &id);
  return QueryHandle(id);
}

BufferHandle createBufferWithData(const void* data, std::size_t bytes, GLbitfield flags) {
  BufferHandle buffer = createBuffer();
  // A zero-sized immutable store is an error in GL; keep one byte so empty layers stay valid.
  glNamedBufferStorage(buffer.id(), static_cast<GLsizeiptr>(bytes == 0 ? 1 : bytes), bytes == 0 ? nullptr : data,
                       flags);
  return buffer;
}

}  // namespace gis::gfx
