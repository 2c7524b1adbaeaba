#include "mlspaces/sim/renderer.h"

#include <dlfcn.h>
#include <unistd.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/osmesa.h>

#ifndef GL_PACK_INVERT_MESA
#define GL_PACK_INVERT_MESA 0x8758
#endif

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/sim/mujoco_handlers.h"
#include "mlspaces/sim/shadow_fit.h"
#include "shadow_pass.h"

namespace mlspaces::sim {
namespace {

// ---------------------------------------------------------------------------------------------
// Run-time loading of the GL platform libraries (see renderer.h for why they are not linked).

std::string OneLine(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

[[noreturn]] void Fail(GlBackend backend, const std::string& message) {
  throw Error(std::string(GlBackendName(backend)) + " renderer: " + OneLine(message));
}

// Opens the first of `names` that loads (RTLD_LOCAL). Returns the handle and the name that
// loaded.
std::pair<void*, const char*> OpenLibrary(GlBackend backend,
                                          std::initializer_list<const char*> names,
                                          const char* package) {
  std::string errors;
  for (const char* name : names) {
    if (void* h = ::dlopen(name, RTLD_NOW | RTLD_LOCAL)) return {h, name};
    const char* e = ::dlerror();
    if (!errors.empty()) errors += "; ";
    errors += e ? e : name;
  }
  Fail(backend, "cannot load the GL library (install " + std::string(package) + "): " + errors);
}

template <class F>
F Symbol(GlBackend backend, void* lib, const char* name) {
  void* p = ::dlsym(lib, name);
  if (p == nullptr) Fail(backend, std::string("the GL library has no ") + name);
  return reinterpret_cast<F>(p);
}

struct OsMesaApi {
  void* lib = nullptr;
  const char* lib_name = nullptr;
  decltype(&::OSMesaCreateContextExt) create_context_ext = nullptr;
  decltype(&::OSMesaMakeCurrent) make_current = nullptr;
  decltype(&::OSMesaGetCurrentContext) get_current_context = nullptr;
  decltype(&::OSMesaDestroyContext) destroy_context = nullptr;
  decltype(&::OSMesaGetProcAddress) get_proc_address = nullptr;
};

struct EglApi {
  void* lib = nullptr;
  const char* lib_name = nullptr;
  decltype(&::eglGetProcAddress) get_proc_address = nullptr;
  decltype(&::eglQueryString) query_string = nullptr;
  decltype(&::eglGetError) get_error = nullptr;
  decltype(&::eglInitialize) initialize = nullptr;
  decltype(&::eglTerminate) terminate = nullptr;
  decltype(&::eglChooseConfig) choose_config = nullptr;
  decltype(&::eglBindAPI) bind_api = nullptr;
  decltype(&::eglCreateContext) create_context = nullptr;
  decltype(&::eglDestroyContext) destroy_context = nullptr;
  decltype(&::eglMakeCurrent) make_current = nullptr;
  decltype(&::eglGetCurrentContext) get_current_context = nullptr;
  PFNEGLGETPLATFORMDISPLAYEXTPROC get_platform_display = nullptr;
  // EGL_EXT_device_enumeration (null without it): the device platform's devices.
  PFNEGLQUERYDEVICESEXTPROC query_devices = nullptr;
  PFNEGLQUERYDEVICESTRINGEXTPROC query_device_string = nullptr;
  bool has_surfaceless = false;  // EGL_MESA_platform_surfaceless
};

// Loaded once per process; a failed load is retried by the next call.
const OsMesaApi& LoadOsMesa() {
  static const OsMesaApi api = [] {
    constexpr GlBackend b = GlBackend::kOsMesa;
    OsMesaApi a;
    std::tie(a.lib, a.lib_name) =
        OpenLibrary(b, {"libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"}, "libosmesa6");
    a.create_context_ext =
        Symbol<decltype(a.create_context_ext)>(b, a.lib, "OSMesaCreateContextExt");
    a.make_current = Symbol<decltype(a.make_current)>(b, a.lib, "OSMesaMakeCurrent");
    a.get_current_context =
        Symbol<decltype(a.get_current_context)>(b, a.lib, "OSMesaGetCurrentContext");
    a.destroy_context = Symbol<decltype(a.destroy_context)>(b, a.lib, "OSMesaDestroyContext");
    a.get_proc_address = Symbol<decltype(a.get_proc_address)>(b, a.lib, "OSMesaGetProcAddress");
    return a;
  }();
  return api;
}

const EglApi& LoadEgl() {
  static const EglApi api = [] {
    constexpr GlBackend b = GlBackend::kEgl;
    EglApi a;
    std::tie(a.lib, a.lib_name) =
        OpenLibrary(b, {"libEGL.so.1", "libEGL.so"}, "libegl1 and libegl-mesa0");
    a.get_proc_address = Symbol<decltype(a.get_proc_address)>(b, a.lib, "eglGetProcAddress");
    a.query_string = Symbol<decltype(a.query_string)>(b, a.lib, "eglQueryString");
    a.get_error = Symbol<decltype(a.get_error)>(b, a.lib, "eglGetError");
    a.initialize = Symbol<decltype(a.initialize)>(b, a.lib, "eglInitialize");
    a.terminate = Symbol<decltype(a.terminate)>(b, a.lib, "eglTerminate");
    a.choose_config = Symbol<decltype(a.choose_config)>(b, a.lib, "eglChooseConfig");
    a.bind_api = Symbol<decltype(a.bind_api)>(b, a.lib, "eglBindAPI");
    a.create_context = Symbol<decltype(a.create_context)>(b, a.lib, "eglCreateContext");
    a.destroy_context = Symbol<decltype(a.destroy_context)>(b, a.lib, "eglDestroyContext");
    a.make_current = Symbol<decltype(a.make_current)>(b, a.lib, "eglMakeCurrent");
    a.get_current_context =
        Symbol<decltype(a.get_current_context)>(b, a.lib, "eglGetCurrentContext");
    const char* ext_c = a.query_string(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    const std::string_view ext = ext_c ? ext_c : "";
    a.has_surfaceless = ext.find("EGL_MESA_platform_surfaceless") != std::string_view::npos;
    a.get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        a.get_proc_address("eglGetPlatformDisplayEXT"));
    if (a.get_platform_display == nullptr) Fail(b, "EGL has no eglGetPlatformDisplayEXT");
    if (ext.find("EGL_EXT_platform_device") != std::string_view::npos) {
      a.query_devices =
          reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(a.get_proc_address("eglQueryDevicesEXT"));
      a.query_device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
          a.get_proc_address("eglQueryDeviceStringEXT"));
    }
    return a;
  }();
  return api;
}

std::string EglErrorText(const EglApi& egl) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "EGL error 0x%04X", static_cast<unsigned>(egl.get_error()));
  return buf;
}

// The EGL devices (EGL_EXT_device_enumeration), queried once per process.
std::vector<EGLDeviceEXT> QueryEglDevices(const EglApi& egl) {
  if (egl.query_devices == nullptr) {
    Fail(GlBackend::kEgl, "EGL has no device platform (EGL_EXT_platform_device)");
  }
  EGLint count = 0;
  if (!egl.query_devices(0, nullptr, &count) || count < 1) {
    Fail(GlBackend::kEgl, "no EGL device (" + EglErrorText(egl) + ")");
  }
  std::vector<EGLDeviceEXT> devices(static_cast<size_t>(count));
  if (!egl.query_devices(count, devices.data(), &count)) {
    Fail(GlBackend::kEgl, "eglQueryDevicesEXT failed (" + EglErrorText(egl) + ")");
  }
  devices.resize(static_cast<size_t>(count));
  return devices;
}

const std::vector<EGLDeviceEXT>& EglDeviceHandles(const EglApi& egl) {
  static const std::vector<EGLDeviceEXT> devices = QueryEglDevices(egl);
  return devices;
}

// The EGL display of each device (key: device index; -1 for the surfaceless platform),
// initialised while any EGL Renderer on it lives (eglInitialize and eglTerminate act on the
// display as a whole, so they are reference-counted).
std::mutex g_egl_mutex;
struct EglDisplaySlot {
  EGLDisplay display = EGL_NO_DISPLAY;
  int users = 0;
};
std::map<int, EglDisplaySlot> g_egl_displays;

std::string EglDisplayName(int device) {
  return device < 0 ? std::string("the surfaceless EGL display")
                    : "EGL device " + std::to_string(device);
}

// The display of `device` (an index of the device list), or of Mesa's surfaceless platform
// (no window system, no GPU needed) for -1.
EGLDisplay OpenEglDisplay(const EglApi& egl, int device) {
  if (device < 0) {
    if (!egl.has_surfaceless) {
      Fail(GlBackend::kEgl, "EGL has no EGL_MESA_platform_surfaceless (install libegl-mesa0)");
    }
    return egl.get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  }
  const std::vector<EGLDeviceEXT>& devices = EglDeviceHandles(egl);
  if (static_cast<size_t>(device) >= devices.size()) {
    throw UsageError("egl renderer: no EGL device " + std::to_string(device) + " (there are " +
                     std::to_string(devices.size()) + ")");
  }
  return egl.get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[static_cast<size_t>(device)],
                                  nullptr);
}

EGLDisplay AcquireEglDisplay(const EglApi& egl, int device) {
  std::lock_guard lock(g_egl_mutex);
  EglDisplaySlot& slot = g_egl_displays[device];
  if (slot.users == 0) {
    EGLDisplay dpy = OpenEglDisplay(egl, device);
    if (dpy == EGL_NO_DISPLAY) {
      Fail(GlBackend::kEgl,
           "no display for " + EglDisplayName(device) + " (" + EglErrorText(egl) + ")");
    }
    EGLint major = 0, minor = 0;
    if (!egl.initialize(dpy, &major, &minor)) {
      Fail(GlBackend::kEgl,
           "cannot initialise " + EglDisplayName(device) + " (" + EglErrorText(egl) + ")");
    }
    slot.display = dpy;
  }
  ++slot.users;
  return slot.display;
}

void ReleaseEglDisplay(const EglApi& egl, int device) {
  std::lock_guard lock(g_egl_mutex);
  EglDisplaySlot& slot = g_egl_displays[device];
  if (--slot.users == 0) {
    egl.terminate(slot.display);
    slot.display = EGL_NO_DISPLAY;
  }
}

// MuJoCo 3.5 takes its GL functions from the GL platform library it finds loaded in the
// process (dl_iterate_phdr), preferring libEGL over libOSMesa whatever context is current: an
// OSMesa context in a process that has loaded libEGL renders nothing ("gladLoadGL error").
// That is why the platform libraries are loaded at run time, only the one a process uses, and
// why the first Renderer fixes the process's backend.
std::mutex g_backend_mutex;
std::optional<GlBackend> g_process_backend;
pid_t g_process_backend_pid = 0;  // the process that claimed it (fork check)

// Throws when the process is already fixed to the other backend. Caller holds the mutex.
void CheckProcessBackendLocked(GlBackend backend) {
  // Mesa keeps process-wide GL state (llvmpipe's rasteriser threads among it) that a fork()ed
  // child inherits without the threads: a context made there waits for them forever.
  if (g_process_backend && g_process_backend_pid != ::getpid()) {
    Fail(backend,
         "this process was forked from one that had rendered, and GL state does not "
         "survive fork(): render only in processes started fresh (multiprocessing "
         "'spawn' or 'forkserver', e.g. AsyncVectorEnv(..., context='spawn')), or fork "
         "before the first render");
  }
  if (g_process_backend && *g_process_backend != backend) {
    Fail(backend, "this process already renders with " +
                      std::string(GlBackendName(*g_process_backend)) +
                      " (MuJoCo takes its GL functions from the platform library loaded in the "
                      "process: use one backend per process)");
  }
}

void CheckProcessBackend(GlBackend backend) {
  std::lock_guard lock(g_backend_mutex);
  CheckProcessBackendLocked(backend);
}

void ClaimProcessBackend(GlBackend backend) {
  std::lock_guard lock(g_backend_mutex);
  CheckProcessBackendLocked(backend);  // another thread may have claimed it meanwhile
  g_process_backend = backend;
  g_process_backend_pid = ::getpid();
}

// ---------------------------------------------------------------------------------------------
// A GL context of either backend; owns it and destroys it.

// GL functions by name, for ShadowPass.
void* OsMesaProc(const char* name) {
  return reinterpret_cast<void*>(LoadOsMesa().get_proc_address(name));
}
void* EglProc(const char* name) {
  return reinterpret_cast<void*>(LoadEgl().get_proc_address(name));
}

class GlContext {
 public:
  // `device`: for EGL, an index of the device list, or -1 for the surfaceless platform.
  GlContext(GlBackend backend, int device, int width, int height)
      : backend_(backend), device_(device) {
    if (backend == GlBackend::kOsMesa) {
      const OsMesaApi& api = LoadOsMesa();
      osmesa_ = api.create_context_ext(OSMESA_RGBA, 24, 8, 8, nullptr);
      if (osmesa_ == nullptr) Fail(backend, "OSMesaCreateContextExt failed");
      osmesa_buffer_.resize(static_cast<size_t>(width) * height * 4);
      width_ = width;
      height_ = height;
      if (!api.make_current(osmesa_, osmesa_buffer_.data(), GL_UNSIGNED_BYTE, width, height)) {
        api.destroy_context(osmesa_);
        Fail(backend, "OSMesaMakeCurrent failed");
      }
    } else {
      const EglApi& egl = LoadEgl();
      display_ = AcquireEglDisplay(egl, device_);
      const EGLint attribs[] = {EGL_RED_SIZE,
                                8,
                                EGL_GREEN_SIZE,
                                8,
                                EGL_BLUE_SIZE,
                                8,
                                EGL_ALPHA_SIZE,
                                8,
                                EGL_DEPTH_SIZE,
                                24,
                                EGL_STENCIL_SIZE,
                                8,
                                EGL_COLOR_BUFFER_TYPE,
                                EGL_RGB_BUFFER,
                                EGL_SURFACE_TYPE,
                                EGL_PBUFFER_BIT,
                                EGL_RENDERABLE_TYPE,
                                EGL_OPENGL_BIT,
                                EGL_NONE};
      EGLConfig config = nullptr;
      EGLint n = 0;
      std::string problem;
      if (!egl.choose_config(display_, attribs, &config, 1, &n) || n < 1) {
        problem = "no EGL config with RGBA8, depth 24, stencil 8 and desktop OpenGL";
      } else if (!egl.bind_api(EGL_OPENGL_API)) {
        problem = "eglBindAPI(EGL_OPENGL_API) failed (" + EglErrorText(egl) + ")";
      } else if ((egl_ = egl.create_context(display_, config, EGL_NO_CONTEXT, nullptr)) ==
                 EGL_NO_CONTEXT) {
        problem = "eglCreateContext failed (" + EglErrorText(egl) + ")";
      } else if (!egl.make_current(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, egl_)) {
        problem = "surfaceless eglMakeCurrent failed (" + EglErrorText(egl) + ")";
        egl.destroy_context(display_, egl_);
      }
      if (!problem.empty()) {
        ReleaseEglDisplay(egl, device_);
        Fail(backend, problem + " on " + EglDisplayName(device_));
      }
    }
  }

  ~GlContext() {
    // The GL library was loaded when this context was made, so LoadOsMesa/LoadEgl return
    // their cached tables here; the try only keeps the destructor from throwing.
    try {
      if (backend_ == GlBackend::kOsMesa) {
        const OsMesaApi& api = LoadOsMesa();
        if (api.get_current_context() == osmesa_) api.make_current(nullptr, nullptr, 0, 0, 0);
        api.destroy_context(osmesa_);
      } else {
        const EglApi& egl = LoadEgl();
        if (egl.get_current_context() == egl_) {
          egl.make_current(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        }
        egl.destroy_context(display_, egl_);
        ReleaseEglDisplay(egl, device_);
      }
    } catch (...) {}
  }

  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void MakeCurrent() {
    if (backend_ == GlBackend::kOsMesa) {
      const OsMesaApi& api = LoadOsMesa();
      if (api.get_current_context() == osmesa_) return;
      if (!api.make_current(osmesa_, osmesa_buffer_.data(), GL_UNSIGNED_BYTE, width_, height_)) {
        Fail(backend_, "OSMesaMakeCurrent failed");
      }
    } else {
      const EglApi& egl = LoadEgl();
      if (egl.get_current_context() == egl_) return;
      egl.bind_api(EGL_OPENGL_API);  // per-thread state: this thread may never have set it
      if (!egl.make_current(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, egl_)) {
        Fail(backend_, "eglMakeCurrent failed (" + EglErrorText(egl) +
                           "; is this Renderer current in another thread?)");
      }
    }
  }

 private:
  GlBackend backend_;
  int device_ = -1;
  OSMesaContext osmesa_ = nullptr;
  std::vector<unsigned char> osmesa_buffer_;
  int width_ = 0, height_ = 0;
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext egl_ = EGL_NO_CONTEXT;
};

template <class T>
void FlipRows(T* pixels, int width, int height, int channels) {
  const size_t row = static_cast<size_t>(width) * channels;
  for (int top = 0, bottom = height - 1; top < bottom; ++top, --bottom) {
    std::swap_ranges(pixels + top * row, pixels + (top + 1) * row, pixels + bottom * row);
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------

GlBackend ParseGlBackend(std::string_view name) {
  if (name == "osmesa") return GlBackend::kOsMesa;
  if (name == "egl") return GlBackend::kEgl;
  throw UsageError("unknown GL backend '" + std::string(name) + "' (expected osmesa or egl)");
}

std::string_view GlBackendName(GlBackend backend) {
  return backend == GlBackend::kEgl ? "egl" : "osmesa";
}

std::optional<GlBackend> ProcessGlBackend() {
  std::lock_guard lock(g_backend_mutex);
  return g_process_backend;
}

// ---------------------------------------------------------------------------------------------
// EGL devices

namespace {

std::atomic<int> g_render_worker{0};

std::string DescribeEglDevices(const std::vector<EglDevice>& devices) {
  std::string out;
  for (const EglDevice& d : devices) {
    if (!out.empty()) out += ", ";
    out += std::to_string(d.index) + " (" + d.name + ")";
  }
  return out;
}

// MLSPACES_EGL_DEVICE's indices; empty when it is unset or empty.
std::vector<int> EnvEglDevices(const std::vector<EglDevice>& devices) {
  const char* env = std::getenv("MLSPACES_EGL_DEVICE");
  std::vector<int> out;
  if (env == nullptr || *env == '\0') return out;
  const std::string_view text = env;
  auto bad = [&](const std::string& why) {
    throw UsageError("MLSPACES_EGL_DEVICE=" + std::string(text) + ": " + why +
                     " (devices: " + DescribeEglDevices(devices) + ")");
  };
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string_view part = text.substr(start, comma - start);
    int value = -1;
    const auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), value);
    if (part.empty() || ec != std::errc() || ptr != part.data() + part.size() || value < 0) {
      bad("expected a device index or a comma-separated list of them");
    }
    if (static_cast<size_t>(value) >= devices.size()) {
      bad("no EGL device " + std::to_string(value));
    }
    out.push_back(value);
    start = comma + 1;
  }
  return out;
}

// The devices that automatic choice takes in turn: the hardware ones, else all.
std::vector<int> AutoEglDevices(const std::vector<EglDevice>& devices) {
  std::vector<int> hardware, all;
  for (const EglDevice& d : devices) {
    all.push_back(d.index);
    if (!d.software) hardware.push_back(d.index);
  }
  return hardware.empty() ? all : hardware;
}

}  // namespace

std::vector<EglDevice> ListEglDevices() {
  const EglApi& egl = LoadEgl();
  const std::vector<EGLDeviceEXT>& handles = EglDeviceHandles(egl);
  std::vector<EglDevice> out;
  for (size_t i = 0; i < handles.size(); ++i) {
    EglDevice d;
    d.index = static_cast<int>(i);
    const char* ext =
        egl.query_device_string ? egl.query_device_string(handles[i], EGL_EXTENSIONS) : nullptr;
    d.software = ext != nullptr &&
                 std::string_view(ext).find("EGL_MESA_device_software") != std::string_view::npos;
    const char* file = nullptr;
    if (ext != nullptr &&
        std::string_view(ext).find("EGL_EXT_device_drm") != std::string_view::npos) {
      file = egl.query_device_string(handles[i], EGL_DRM_DEVICE_FILE_EXT);
    }
    d.name = file != nullptr ? file : d.software ? "software" : "device " + std::to_string(i);
    out.push_back(std::move(d));
  }
  return out;
}

int ChooseEglDevice(int worker) {
  const std::vector<EglDevice> devices = ListEglDevices();
  std::vector<int> pool = EnvEglDevices(devices);
  if (pool.empty()) pool = AutoEglDevices(devices);
  return pool[static_cast<size_t>(std::max(0, worker)) % pool.size()];
}

void SetRenderWorker(int worker) { g_render_worker = std::max(0, worker); }

struct Renderer::Impl {
  RenderOptions options;
  int egl_device = -1;
  // Declared first, destroyed last: the MuJoCo objects below are freed with it current.
  std::optional<GlContext> gl;
  ModelPtr model;  // private copy with a big enough offscreen buffer
  mjvOption opt{};
  mjvCamera cam{};
  mjvScene scn{};
  mjrContext con{};
  bool scene_made = false;
  bool context_made = false;
  float znear = 0, zfar = 0;
  // MuJoCo's shadow square, as mjr_makeContext sets mjrContext::shadowClip.
  float default_clip = 0;
  // RenderOptions::one_pass_shadows; its GL objects are freed before MuJoCo's.
  std::unique_ptr<ShadowPass> shadow_pass;
  // glPixelStorei when the driver reads rows top down (GL_MESA_pack_invert: Mesa's drivers),
  // which saves flipping them after mjr_readPixels; null otherwise.
  decltype(&::glPixelStorei) pack_invert = nullptr;
  long long frames = 0, one_pass_frames = 0;
  std::string one_pass_missed;  // why one pass could not draw the last frame it missed

  ~Impl() {
    if (context_made && gl) {
      try {
        gl->MakeCurrent();
        shadow_pass.reset();
        mjr_freeContext(&con);
      } catch (...) {  // cannot make it current: leave the GL objects to the context's end
      }
    }
    if (scene_made) mjv_freeScene(&scn);
  }
};

namespace {

// The map side for fitted shadows: the texel size of a shadowsize² map over MuJoCo's square,
// on the square that fits the casters at the model's initial state plus a quarter for motion
// (FitShadowMaps fits each frame; the map size is fixed with the context).
int FittedShadowSize(const mjModel* m, Renderer::Impl& s) {
  const int full = m->vis.quality.shadowsize;
  const float default_clip = s.default_clip;
  DataPtr d = MakeData(m);
  mj_forward(m, d.get());
  mjv_updateScene(m, d.get(), &s.opt, nullptr, &s.cam, mjCAT_ALL, &s.scn);
  mjrContext probe;
  mjr_defaultContext(&probe);
  probe.shadowSize = full;
  const ShadowFit fit = FitShadowMaps(m, &s.scn, &probe, default_clip);
  if (!fit.fitted || !(default_clip > 0)) return full;
  const double share = std::min(1.0, 1.25 * fit.clip / default_clip);
  return std::max(64, static_cast<int>(std::ceil(full * share)));
}

}  // namespace

Renderer::Renderer(const mjModel* m, RenderOptions options) : impl_(std::make_unique<Impl>()) {
  InstallMujocoHandlers();
  if (m == nullptr) throw UsageError("Renderer: null model");
  if (options.width <= 0 || options.height <= 0) {
    throw UsageError("Renderer: image size must be positive, got " + std::to_string(options.width) +
                     "x" + std::to_string(options.height));
  }
  if (options.max_geom <= 0) throw UsageError("Renderer: max_geom must be positive");
  const GlBackend backend = options.backend;
  CheckProcessBackend(backend);
  if (options.shadow_size < 0) {
    throw UsageError("Renderer: shadow_size must be >= 0 (0: the model's), got " +
                     std::to_string(options.shadow_size));
  }
  if (options.multisamples < -1) {
    throw UsageError("Renderer: multisamples must be >= -1 (-1: the model's), got " +
                     std::to_string(options.multisamples));
  }
  Impl& s = *impl_;
  s.options = options;
  if (backend == GlBackend::kOsMesa || options.egl_platform == EglPlatform::kSurfaceless) {
    s.gl.emplace(backend, -1, options.width, options.height);
  } else {
    // The device platform: the device asked for, or this worker's, then (automatic choice
    // without MLSPACES_EGL_DEVICE only) the other devices of the pool until one works.
    const std::vector<EglDevice> devices = ListEglDevices();
    std::vector<int> candidates;
    if (options.egl_device >= 0) {
      if (static_cast<size_t>(options.egl_device) >= devices.size()) {
        throw UsageError("Renderer: no EGL device " + std::to_string(options.egl_device) +
                         " (devices: " + DescribeEglDevices(devices) + ")");
      }
      candidates = {options.egl_device};
    } else {
      const int first = ChooseEglDevice(g_render_worker);
      candidates = {first};
      if (EnvEglDevices(devices).empty()) {
        for (int d : AutoEglDevices(devices)) {
          if (d != first) candidates.push_back(d);
        }
      }
    }
    std::string failures;
    for (const int d : candidates) {
      try {
        s.gl.emplace(backend, d, options.width, options.height);
        s.egl_device = d;
        break;
      } catch (const Error& e) {
        if (!failures.empty()) failures += "; ";
        failures += e.what();
      }
    }
    if (!s.gl) {
      if (candidates.size() == 1) throw Error(failures);
      Fail(backend, "no EGL device works: " + failures);
    }
  }
  try {
    s.model.reset(mj_copyModel(nullptr, m));
    if (!s.model) Fail(backend, "mj_copyModel failed");
    mjModel* mc = s.model.get();
    // The offscreen buffer of exactly the picture's size: a clear scissored to a part of the
    // buffer (mjr_render's and the one pass's) is a drawn quad on llvmpipe, a whole one a
    // memset, and the clears that are not scissored touch no unused rows.
    mc->vis.global.offwidth = options.width;
    mc->vis.global.offheight = options.height;
    if (options.shadow_size > 0) mc->vis.quality.shadowsize = options.shadow_size;
    if (options.multisamples >= 0) mc->vis.quality.offsamples = options.multisamples;
    s.znear = static_cast<float>(mc->vis.map.znear * mc->stat.extent);
    s.zfar = static_cast<float>(mc->vis.map.zfar * mc->stat.extent);

    mjv_defaultOption(&s.opt);
    mjv_defaultCamera(&s.cam);
    s.cam.type = mjCAMERA_FREE;
    mjv_defaultScene(&s.scn);
    s.scene_made = true;  // mjv_freeScene is safe on a default or partly made scene
    mjv_makeScene(mc, &s.scn, options.max_geom);
    s.default_clip = static_cast<float>(mc->stat.extent * mc->vis.map.shadowclip);
    if (options.fit_shadows) mc->vis.quality.shadowsize = FittedShadowSize(mc, s);

    mjr_defaultContext(&s.con);
    ClaimProcessBackend(backend);
    s.context_made = true;  // mjr_freeContext frees whatever a failed make left
    mjr_makeContext(mc, &s.con, mjFONTSCALE_100);
    mjr_setBuffer(mjFB_OFFSCREEN, &s.con);
    if (s.con.currentBuffer != mjFB_OFFSCREEN || s.con.offWidth < options.width ||
        s.con.offHeight < options.height) {
      Fail(backend, "MuJoCo has no " + std::to_string(options.width) + "x" +
                        std::to_string(options.height) + " offscreen buffer (got " +
                        std::to_string(s.con.offWidth) + "x" + std::to_string(s.con.offHeight) +
                        ")");
    }
    const GlProcLoader load = backend == GlBackend::kOsMesa ? &OsMesaProc : &EglProc;
    const auto get_string = reinterpret_cast<decltype(&::glGetString)>(load("glGetString"));
    const auto* extensions =
        get_string != nullptr ? reinterpret_cast<const char*>(get_string(GL_EXTENSIONS)) : nullptr;
    if (extensions != nullptr && std::strstr(extensions, "GL_MESA_pack_invert") != nullptr) {
      s.pack_invert = reinterpret_cast<decltype(&::glPixelStorei)>(load("glPixelStorei"));
    }
    if (options.one_pass_shadows) {
      try {
        s.shadow_pass = std::make_unique<ShadowPass>(load, mc, options.coarse_sides);
      } catch (const Error& e) {
        Fail(backend, std::string(e.what()) +
                          " (one_pass_shadows off, camera_config.one_pass_shadows: false in a"
                          " datagen config, renders with MuJoCo's own passes)");
      }
    }
  } catch (const MujocoError& e) {
    Fail(backend, std::string("MuJoCo cannot make its render context: ") + e.what());
  }
}

Renderer::~Renderer() = default;

void Renderer::Render(const mjData* d, const CameraView& view, unsigned char* rgb, float* depth_m) {
  Impl& s = *impl_;
  if (d == nullptr || rgb == nullptr) throw UsageError("Renderer::Render: null data or rgb");
  if (!(view.fovy_deg > 0 && view.fovy_deg < 180)) {
    throw UsageError("Renderer::Render: fovy_deg must be in (0, 180), got " +
                     std::to_string(view.fovy_deg));
  }
  s.gl->MakeCurrent();
  s.cam.type = mjCAMERA_FREE;
  // mjv_updateScene only uses d's scratch stack (restored before it returns).
  mjv_updateScene(s.model.get(), const_cast<mjData*>(d), &s.opt, nullptr, &s.cam, mjCAT_ALL,
                  &s.scn);
  // Replace the free camera by `view`, as mjv_updateCamera builds a fixed camera: both eyes
  // at the same place (mono rendering averages them).
  // As mjv_updateCamera: the near plane in double, then rounded to float.
  const double znear = s.model->vis.map.znear * s.model->stat.extent;
  const double top = znear * std::tan(view.fovy_deg * mjPI / 360.0);
  for (mjvGLCamera& c : s.scn.camera) {
    for (int i = 0; i < 3; ++i) {
      c.pos[i] = static_cast<float>(view.pos[i]);
      c.forward[i] = static_cast<float>(-view.xmat[3 * i + 2]);
      c.up[i] = static_cast<float>(view.xmat[3 * i + 1]);
    }
    c.frustum_center = 0;
    c.frustum_top = static_cast<float>(top);
    c.frustum_bottom = static_cast<float>(-top);
    c.frustum_near = s.znear;
    c.frustum_far = s.zfar;
  }
  // MuJoCo 3 places the headlight in mjv_updateScene, at the camera: move it with the view.
  for (int i = 0; i < s.scn.nlight; ++i) {
    mjvLight& l = s.scn.lights[i];
    if (!l.headlight) continue;
    for (int k = 0; k < 3; ++k) {
      l.pos[k] = static_cast<float>(view.pos[k]);
      l.dir[k] = static_cast<float>(-view.xmat[3 * k + 2]);
    }
  }
  Draw(rgb, depth_m);
}

void Renderer::RenderCamera(const mjData* d, int camera_id, unsigned char* rgb, float* depth_m) {
  Impl& s = *impl_;
  if (d == nullptr || rgb == nullptr) {
    throw UsageError("Renderer::RenderCamera: null data or rgb");
  }
  if (camera_id < 0 || camera_id >= s.model->ncam) {
    throw UsageError("Renderer::RenderCamera: camera id " + std::to_string(camera_id) +
                     " out of range (the model has " + std::to_string(s.model->ncam) + " cameras)");
  }
  s.gl->MakeCurrent();
  s.cam.type = mjCAMERA_FIXED;
  s.cam.fixedcamid = camera_id;
  mjv_updateScene(s.model.get(), const_cast<mjData*>(d), &s.opt, nullptr, &s.cam, mjCAT_ALL,
                  &s.scn);
  Draw(rgb, depth_m);
}

void Renderer::Draw(unsigned char* rgb, float* depth_m) {
  Impl& s = *impl_;
  const int w = s.options.width, h = s.options.height;
  const mjrRect viewport{0, 0, w, h};
  mjr_setBuffer(mjFB_OFFSCREEN, &s.con);
  if (s.options.fit_shadows) FitShadowMaps(s.model.get(), &s.scn, &s.con, s.default_clip);
  ++s.frames;
  int geom = -1;
  const bool one_pass = s.shadow_pass && ShadowPass::HasShadows(s.scn, s.con);
  const char* missed = one_pass ? s.shadow_pass->Unsupported(s.scn, s.con, &geom) : nullptr;
  if (one_pass && missed == nullptr) {
    s.shadow_pass->Render(viewport, &s.scn, &s.con);
    ++s.one_pass_frames;
  } else {
    if (missed != nullptr) {
      s.one_pass_missed = missed;
      const mjvGeom* g = geom >= 0 ? &s.scn.geoms[geom] : nullptr;
      if (g != nullptr && g->objtype == mjOBJ_GEOM) {
        const std::string name = MjName(s.model.get(), mjOBJ_GEOM, g->objid);
        s.one_pass_missed +=
            name.empty() ? " (geom " + std::to_string(g->objid) + ")" : " ('" + name + "')";
      }
    }
    mjr_render(viewport, &s.scn, &s.con);
  }
  if (s.pack_invert != nullptr) s.pack_invert(GL_PACK_INVERT_MESA, GL_TRUE);
  mjr_readPixels(rgb, depth_m, viewport, &s.con);
  if (s.pack_invert != nullptr) {
    s.pack_invert(GL_PACK_INVERT_MESA, GL_FALSE);
  } else {
    FlipRows(rgb, w, h, 3);
  }
  if (depth_m != nullptr) {
    // Nonlinear [0,1] depth buffer -> distance along the view axis (platform.md, "Depth").
    const double n = s.znear, ratio = 1.0 - static_cast<double>(s.znear) / s.zfar;
    const size_t count = static_cast<size_t>(w) * h;
    for (size_t i = 0; i < count; ++i) {
      depth_m[i] = static_cast<float>(n / (1.0 - depth_m[i] * ratio));
    }
    if (s.pack_invert == nullptr) FlipRows(depth_m, w, h, 1);
  }
}

CameraView LookAt(const std::array<double, 3>& eye, const std::array<double, 3>& target,
                  double fovy_deg) {
  // z (backward) = eye - target; x (right) = world up x z; y (up) = z x x.
  mjtNum z[3] = {eye[0] - target[0], eye[1] - target[1], eye[2] - target[2]};
  if (mju_normalize3(z) < mjMINVAL) throw UsageError("LookAt: eye and target coincide");
  mjtNum up[3] = {0, 0, 1};
  if (std::abs(z[2]) > 1 - 1e-9) {  // vertical view: world +y up in the image
    up[1] = 1;
    up[2] = 0;
  }
  mjtNum x[3], y[3];
  mju_cross(x, up, z);
  mju_normalize3(x);
  mju_cross(y, z, x);
  CameraView v;
  v.pos = eye;
  for (int i = 0; i < 3; ++i) {
    v.xmat[3 * i + 0] = x[i];
    v.xmat[3 * i + 1] = y[i];
    v.xmat[3 * i + 2] = z[i];
  }
  v.fovy_deg = fovy_deg;
  return v;
}

CameraView Renderer::ModelCamera(const mjModel* m, const mjData* d, int camera_id) {
  if (m == nullptr || d == nullptr) throw UsageError("Renderer::ModelCamera: null model or data");
  if (camera_id < 0 || camera_id >= m->ncam) {
    throw UsageError("Renderer::ModelCamera: camera id " + std::to_string(camera_id) +
                     " out of range (the model has " + std::to_string(m->ncam) + " cameras)");
  }
  CameraView v;
  std::copy_n(d->cam_xpos + 3 * camera_id, 3, v.pos.begin());
  std::copy_n(d->cam_xmat + 9 * camera_id, 9, v.xmat.begin());
  v.fovy_deg = m->cam_fovy[camera_id];
  return v;
}

int Renderer::width() const { return impl_->options.width; }
int Renderer::height() const { return impl_->options.height; }
GlBackend Renderer::backend() const { return impl_->options.backend; }
int Renderer::egl_device() const { return impl_->egl_device; }
int Renderer::shadow_size() const { return impl_->con.shadowSize; }
long long Renderer::frames() const { return impl_->frames; }
long long Renderer::one_pass_frames() const { return impl_->one_pass_frames; }
const std::string& Renderer::one_pass_missed() const { return impl_->one_pass_missed; }
long long Renderer::shadow_map_renders() const {
  return impl_->shadow_pass ? impl_->shadow_pass->map_renders() : 0;
}
long long Renderer::one_pass_left_out() const {
  return impl_->shadow_pass ? impl_->shadow_pass->left_out() : 0;
}
long long Renderer::one_pass_coarse_draws() const {
  return impl_->shadow_pass ? impl_->shadow_pass->coarse_draws() : 0;
}
long long Renderer::one_pass_culled_draws() const {
  return impl_->shadow_pass ? impl_->shadow_pass->culled_draws() : 0;
}
mjvScene& Renderer::scene() { return impl_->scn; }
mjvOption& Renderer::vis_option() { return impl_->opt; }

}  // namespace mlspaces::sim
