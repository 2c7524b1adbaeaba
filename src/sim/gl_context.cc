#include "gl_context.h"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <tuple>

#include "mlspaces/core/error.h"

namespace mlspaces::sim {
namespace {

using gl::Fail;

// ---------------------------------------------------------------------------------------------
// Run-time loading of the GL platform libraries (see renderer.h for why they are not linked).

std::string OneLine(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
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

// This process's worker of a pool (SetRenderWorker).
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

namespace gl {

[[noreturn]] void Fail(GlBackend backend, const std::string& message) {
  throw Error(std::string(GlBackendName(backend)) + " renderer: " + OneLine(message));
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

// GL functions by name, for ShadowPass.
void* OsMesaProc(const char* name) {
  return reinterpret_cast<void*>(LoadOsMesa().get_proc_address(name));
}
void* EglProc(const char* name) {
  return reinterpret_cast<void*>(LoadEgl().get_proc_address(name));
}

Context::Context(GlBackend backend, int device, int width, int height)
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

Context::~Context() {
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

void Context::MakeCurrent() {
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

int MakeContext(const RenderOptions& options, std::optional<Context>& out) {
  const GlBackend backend = options.backend;
  int device = -1;
  if (backend == GlBackend::kOsMesa || options.egl_platform == EglPlatform::kSurfaceless) {
    out.emplace(backend, -1, options.width, options.height);
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
        out.emplace(backend, d, options.width, options.height);
        device = d;
        break;
      } catch (const Error& e) {
        if (!failures.empty()) failures += "; ";
        failures += e.what();
      }
    }
    if (!out) {
      if (candidates.size() == 1) throw Error(failures);
      Fail(backend, "no EGL device works: " + failures);
    }
  }
  return device;
}

}  // namespace gl

// ---------------------------------------------------------------------------------------------

GlBackend ParseGlBackend(std::string_view name) {
  if (name == "osmesa") return GlBackend::kOsMesa;
  if (name == "egl") return GlBackend::kEgl;
  throw UsageError("unknown GL backend '" + std::string(name) + "' (expected osmesa or egl)");
}

GlBackend ResolveGlBackend(std::string_view value, std::string_view flag) {
  std::string_view from = flag;
  if (value.empty()) {
    const char* env = std::getenv("MLSPACES_GL");
    if (env == nullptr || *env == 0) return GlBackend::kOsMesa;
    value = env;
    from = "MLSPACES_GL";
  }
  try {
    return ParseGlBackend(value);
  } catch (const UsageError& e) {
    throw UsageError(std::string(from) + ": " + e.message());
  }
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

}  // namespace mlspaces::sim
