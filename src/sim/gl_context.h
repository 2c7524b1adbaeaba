#pragma once
// The GL platform under the Renderer (internal to mlspaces_sim): libOSMesa and libEGL loaded
// at run time, the EGL devices and their displays, the process's one backend, and a GL
// context of either backend. The public side (ParseGlBackend, ListEglDevices,
// ChooseEglDevice, SetRenderWorker, ...) is declared in mlspaces/sim/renderer.h and defined
// in gl_context.cc.
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/osmesa.h>

#include <optional>
#include <string>
#include <vector>

#include "mlspaces/sim/renderer.h"

namespace mlspaces::sim::gl {

// ---------------------------------------------------------------------------------------------
// Errors and the process's backend

/// @throws Error "<backend> renderer: <message>", the message on one line.
[[noreturn]] void Fail(GlBackend backend, const std::string& message);

/// @throws Error when this process already renders with the other backend, or was forked
/// from one that had rendered (GL state does not survive fork()).
void CheckProcessBackend(GlBackend backend);
/// CheckProcessBackend, then fixes the process's backend (ProcessGlBackend()) to `backend`.
void ClaimProcessBackend(GlBackend backend);

/// GL functions by name, for ShadowPass (a GlProcLoader); null when missing. The backend's
/// library is loaded (a Context of it exists).
void* OsMesaProc(const char* name);
void* EglProc(const char* name);

// ---------------------------------------------------------------------------------------------
// A context

/// A GL context of either backend, with a surface of width x height for OSMesa (EGL renders
/// into framebuffer objects only, surfaceless). Owns the context and destroys it; an EGL
/// context holds a reference on its display while it lives.
class Context {
 public:
  /// `device`: for EGL, an index of ListEglDevices(), or -1 for Mesa's surfaceless platform;
  /// ignored for OSMesa. Leaves the context current on this thread.
  /// @throws Error (one line, naming the display) when the library, display, config or
  /// context fails; UsageError for a device index past the devices.
  Context(GlBackend backend, int device, int width, int height);
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  /// Makes the context current on this thread (nothing when it is already).
  /// @throws Error when it cannot (for EGL: it is current in another thread).
  void MakeCurrent();

 private:
  GlBackend backend_;
  int device_ = -1;
  OSMesaContext osmesa_ = nullptr;
  std::vector<unsigned char> osmesa_buffer_;
  int width_ = 0, height_ = 0;
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext egl_ = EGL_NO_CONTEXT;
};

/// Makes `out` the context `options` asks for: OSMesa, EGL's surfaceless platform, or an EGL
/// device (options.egl_device, else ChooseEglDevice(this process's worker) and then, without
/// MLSPACES_EGL_DEVICE, the pool's other devices until one works). Returns the EGL device
/// index, or -1 when there is none.
/// @throws Error with every device's failure when none works; UsageError for a bad
/// options.egl_device or MLSPACES_EGL_DEVICE.
int MakeContext(const RenderOptions& options, std::optional<Context>& out);

}  // namespace mlspaces::sim::gl
