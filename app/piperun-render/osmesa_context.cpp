#include "osmesa_context.h"

#include <GL/osmesa.h>
#include <vtkGenericOpenGLRenderWindow.h>

#include <stdexcept>

// Debian's VTK 9.1 initialises GLEW, which asks GLX for entry points and then fails in glxewInit
// without an X display. This executable answers both itself: entry points come from OSMesa (the
// executable links libOSMesa before VTK, so gl* symbols resolve there too) and the GLX extension
// check reports success. That interposition is why the headless renderer is its own executable.
extern "C" {
using ProcAddress = void (*)();
ProcAddress glXGetProcAddressARB(const unsigned char* name) {
  return reinterpret_cast<ProcAddress>(OSMesaGetProcAddress(reinterpret_cast<const char*>(name)));
}
ProcAddress glXGetProcAddress(const unsigned char* name) { return glXGetProcAddressARB(name); }
unsigned int glxewInit() { return 0; }  // GLEW_OK
}

namespace piperun::render {

OsMesaContext::OsMesaContext(int width, int height)
    : width_(width), height_(height), buffer_(static_cast<std::size_t>(width) * height * 4) {
  // clang-format off
  const int attributes[] = {OSMESA_FORMAT, OSMESA_RGBA,  // key, value pairs, then 0
                            OSMESA_DEPTH_BITS, 24,
                            OSMESA_STENCIL_BITS, 8,
                            OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION, 3,
                            OSMESA_CONTEXT_MINOR_VERSION, 2,
                            0};
  // clang-format on
  context_ = OSMesaCreateContextAttribs(attributes, nullptr);
  if (!context_) throw std::runtime_error("OSMesa cannot create a 3.2 core-profile context");
  if (!OSMesaMakeCurrent(context_, buffer_.data(), GL_UNSIGNED_BYTE, width, height))
    throw std::runtime_error("OSMesa cannot make its context current");
}

OsMesaContext::~OsMesaContext() { OSMesaDestroyContext(context_); }

void OsMesaContext::attach(vtkGenericOpenGLRenderWindow* window) {
  window->SetSize(width_, height_);
  window->SetOwnContext(false);
  window->SetReadyForRendering(true);
  window->SetIsCurrent(true);
  window->SetMultiSamples(0);
  window->InitializeFromCurrentContext();
}

}  // namespace piperun::render
