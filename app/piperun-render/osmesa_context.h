#pragma once
// An OSMesa core-profile context rendering into memory, handed to a vtkGenericOpenGLRenderWindow.

#include <vector>

class vtkGenericOpenGLRenderWindow;
struct osmesa_context;

namespace piperun::render {

class OsMesaContext {
 public:
  /// Creates a 3.2 core context with a width × height RGBA buffer and makes it current; throws
  /// std::runtime_error when OSMesa cannot.
  OsMesaContext(int width, int height);
  ~OsMesaContext();
  OsMesaContext(const OsMesaContext&) = delete;
  OsMesaContext& operator=(const OsMesaContext&) = delete;

  /// Tells `window` that this context is current and sized, so VTK renders into it.
  void attach(vtkGenericOpenGLRenderWindow* window);

 private:
  osmesa_context* context_ = nullptr;
  int width_, height_;
  std::vector<unsigned char> buffer_;
};

}  // namespace piperun::render
