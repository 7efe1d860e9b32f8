// EGL + GLES 3 compositing, headless or into an X11 window: the camera image with real depth
// written into the depth buffer, then virtual objects depth-tested against it.

#include "dco/compositor/renderer.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>
// After gl3.h, which defines what the extension header builds on.
#include <GLES2/gl2ext.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "x11_window.hpp"

namespace dco::compositor {
namespace {

const char* egl_error_name(EGLint e) {
  switch (e) {
    case EGL_NOT_INITIALIZED:
      return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
      return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
      return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
      return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
      return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
      return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY:
      return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
      return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER:
      return "EGL_BAD_PARAMETER";
    default:
      return "EGL error";
  }
}

[[noreturn]] void egl_fail(const std::string& step) {
  const EGLint e = eglGetError();
  throw Error("EGL: " + step + " failed: " + egl_error_name(e) + " (" + std::to_string(e) + ")");
}

// Every GL error raised since the last check fails the step that raised it.
void check_gl(const char* step) {
  GLenum first = glGetError();
  if (first == GL_NO_ERROR) return;
  while (glGetError() != GL_NO_ERROR) {
  }
  char hex[16];
  std::snprintf(hex, sizeof hex, "0x%04x", first);
  throw Error(std::string("GL: ") + step + " failed: error " + hex);
}

constexpr const char* kFullScreenVs = R"(#version 300 es
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
)";

// The camera image, and the real depth mapped through the same projection as the objects.
constexpr const char* kBackgroundFs = R"(#version 300 es
precision highp float;
uniform highp sampler2D u_depth;
uniform mediump sampler2D u_image;
uniform int u_has_image;
uniform int u_height;
uniform vec2 u_rev;
out vec4 o_color;
void main() {
  ivec2 p = ivec2(int(gl_FragCoord.x), u_height - 1 - int(gl_FragCoord.y));
  float z = texelFetch(u_depth, p, 0).r;
  float g = u_has_image == 1 ? texelFetch(u_image, p, 0).r : 0.5;
  o_color = vec4(g, g, g, 0.0);
  bool known = z > 0.0 && !isinf(z) && !isnan(z);
  gl_FragDepth = known ? clamp(u_rev.x + u_rev.y / z, 0.0, 1.0) : 0.0;
}
)";

constexpr const char* kObjectVs = R"(#version 300 es
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
uniform mat4 u_proj;
out vec3 v_pos;
out vec3 v_normal;
void main() {
  v_pos = a_pos;
  v_normal = a_normal;
  gl_Position = u_proj * vec4(a_pos, 1.0);
}
)";

// Cubes as rasterised; spheres ray-cast per pixel inside their bounding cube, so their outline is
// exact. Soft occlusion: coverage is the share of real depth behind the object around the pixel.
constexpr const char* kObjectFs = R"(#version 300 es
precision highp float;
uniform highp sampler2D u_depth;
uniform int u_height;
uniform int u_width;
uniform vec2 u_rev;
uniform vec4 u_cam;
uniform vec3 u_color;
uniform int u_sphere;
uniform vec4 u_sphere_cr;
uniform int u_soft_radius;
in vec3 v_pos;
in vec3 v_normal;
out vec4 o_color;
float real_depth(ivec2 p) {
  p = clamp(p, ivec2(0), ivec2(u_width - 1, u_height - 1));
  float z = texelFetch(u_depth, p, 0).r;
  return (z > 0.0 && !isinf(z) && !isnan(z)) ? z : 1e30;
}
void main() {
  vec3 pos = v_pos;
  vec3 n = normalize(v_normal);
  if (u_sphere == 1) {
    float u = gl_FragCoord.x - 0.5;
    float v = float(u_height) - gl_FragCoord.y - 0.5;
    vec3 d = vec3((u - u_cam.z) / u_cam.x, (v - u_cam.w) / u_cam.y, 1.0);
    vec3 c = u_sphere_cr.xyz;
    float r = u_sphere_cr.w;
    float a = dot(d, d);
    float b = -2.0 * dot(d, c);
    float cc = dot(c, c) - r * r;
    float disc = b * b - 4.0 * a * cc;
    if (disc < 0.0) discard;
    float t = (-b - sqrt(disc)) / (2.0 * a);
    pos = t * d;
    n = (pos - c) / r;
  }
  gl_FragDepth = clamp(u_rev.x + u_rev.y / pos.z, 0.0, 1.0);
  float coverage = 1.0;
  if (u_soft_radius > 0) {
    ivec2 p = ivec2(int(gl_FragCoord.x), u_height - 1 - int(gl_FragCoord.y));
    int behind = 0;
    int total = 0;
    for (int dy = -u_soft_radius; dy <= u_soft_radius; ++dy)
      for (int dx = -u_soft_radius; dx <= u_soft_radius; ++dx) {
        ++total;
        if (real_depth(p + ivec2(dx, dy)) > pos.z) ++behind;
      }
    coverage = float(behind) / float(total);
    if (coverage <= 0.0) discard;
  }
  float light = 0.35 + 0.65 * max(dot(n, normalize(vec3(-0.4, -0.6, -0.7))), 0.0);
  o_color = vec4(u_color * light, coverage);
}
)";

GLuint compile(GLenum type, const char* source, const char* name) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[1024] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    glDeleteShader(s);
    throw Error(std::string("GL: shader ") + name + " does not compile: " + log);
  }
  return s;
}

GLuint link(const char* vs, const char* fs, const char* name) {
  const GLuint v = compile(GL_VERTEX_SHADER, vs, name);
  const GLuint f = compile(GL_FRAGMENT_SHADER, fs, name);
  const GLuint p = glCreateProgram();
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[1024] = {};
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    glDeleteProgram(p);
    throw Error(std::string("GL: program ") + name + " does not link: " + log);
  }
  check_gl(name);
  return p;
}

// 36 vertices (position, normal) of an axis-aligned box, each triangle wound so that its normal
// points out: counter-clockwise on screen when it faces the camera, so back faces can be culled.
void append_box(std::vector<float>& out, const Vec3& c, float half) {
  for (int axis = 0; axis < 3; ++axis)
    for (int sign : {1, -1}) {
      std::array<float, 3> n{}, t1{}, t2{};
      n[axis] = static_cast<float>(sign);
      t1[(axis + (sign > 0 ? 1 : 2)) % 3] = 1;
      t2[(axis + (sign > 0 ? 2 : 1)) % 3] = 1;
      auto corner = [&](int i, int j) {
        std::array<float, 3> p{};
        for (int k = 0; k < 3; ++k)
          p[k] = c[k] + half * (n[k] + static_cast<float>(2 * i - 1) * t1[k] +
                                static_cast<float>(2 * j - 1) * t2[k]);
        return p;
      };
      for (const auto& [i, j] : {std::pair{0, 0}, {1, 0}, {1, 1}, {0, 0}, {1, 1}, {0, 1}}) {
        const auto p = corner(i, j);
        out.insert(out.end(), {p[0], p[1], p[2], n[0], n[1], n[2]});
      }
    }
}

}  // namespace

bool has_extension(const char* name) {
  GLint count = 0;
  glGetIntegerv(GL_NUM_EXTENSIONS, &count);
  for (GLint i = 0; i < count; ++i) {
    const auto* e =
        reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, static_cast<GLuint>(i)));
    if (e && std::strcmp(e, name) == 0) return true;
  }
  return false;
}

struct Renderer::Impl {
  std::unique_ptr<X11Window> window;  // null: headless
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;
  // GPU timestamps before and after a frame (EXT_disjoint_timer_query); 0 where the GL has none.
  GLuint stamps[2] = {0, 0};
  PFNGLQUERYCOUNTEREXTPROC query_counter = nullptr;
  PFNGLGETQUERYOBJECTUI64VEXTPROC query_result_64 = nullptr;
  GLuint background = 0, object = 0, vao_empty = 0, vao_box = 0, vbo_box = 0;
  GLuint depth_tex = 0, image_tex = 0, fbo = 0, color_rb = 0, depth_rb = 0;
  // Uniform locations, looked up once.
  struct {
    GLint depth, image, has_image, height, rev;
  } bg{};
  struct {
    GLint proj, depth, height, width, rev, cam, soft_radius, color, sphere, sphere_cr;
  } obj{};
  int width = 0, height = 0;              // the framebuffer's: the last frame drawn
  int input_width = 0, input_height = 0;  // the input textures': the last frame uploaded
  std::string egl_display;
  std::vector<std::uint8_t> rgba, flipped;
  std::vector<float> vertices;
  // Each object's box (centre, half side) of this frame and of the geometry in vbo_box (empty
  // until the first upload): the vertices are built and uploaded again only when a box moved,
  // came or went.
  std::vector<float> boxes, uploaded_boxes;

  explicit Impl(const WindowOptions* options, HeadlessDisplay headless = HeadlessDisplay::kAuto) {
    try {
      init(options, headless);
    } catch (...) {
      release();
      throw;
    }
  }
  ~Impl() { release(); }

  // Headless: the first display of those `which` allows that initialises.
  void open_headless(HeadlessDisplay which) {
    std::string tried;
    const auto note = [&](const std::string& failure) {
      tried += (tried.empty() ? "" : "; ") + failure;
    };
    if (which != HeadlessDisplay::kDevice) {
      display = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
      if (display != EGL_NO_DISPLAY && eglInitialize(display, nullptr, nullptr)) {
        egl_display = "surfaceless";
        return;
      }
      note(std::string("surfaceless: ") + egl_error_name(eglGetError()));
      if (which == HeadlessDisplay::kSurfaceless)
        throw Error("EGL: opening the surfaceless display failed: " + tried);
    }
    display = EGL_NO_DISPLAY;
    const auto query_devices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    std::array<EGLDeviceEXT, 16> devices{};
    EGLint count = 0;
    if (query_devices == nullptr)
      note("no EGL device enumeration");
    else if (!query_devices(static_cast<EGLint>(devices.size()), devices.data(), &count) ||
             count == 0)
      note("no EGL device");
    for (EGLint i = 0; i < count; ++i) {
      const EGLDisplay d = eglGetPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
      if (d != EGL_NO_DISPLAY && eglInitialize(d, nullptr, nullptr)) {
        display = d;
        egl_display = "EGL device " + std::to_string(i) + " of " + std::to_string(count);
        return;
      }
      note("EGL device " + std::to_string(i) + ": " + egl_error_name(eglGetError()));
    }
    throw Error("EGL: no headless display: " + tried);
  }

  void init(const WindowOptions* options, HeadlessDisplay headless) {
    if (options) {
      if (options->width <= 0 || options->height <= 0 || options->width > 16384 ||
          options->height > 16384)
        throw Error("compositor: window size " + std::to_string(options->width) + "x" +
                    std::to_string(options->height) + " is outside 1..16384");
      window = std::make_unique<X11Window>(options->display);
      display = eglGetPlatformDisplay(EGL_PLATFORM_X11_KHR, window->native_display(), nullptr);
      if (display == EGL_NO_DISPLAY) egl_fail("opening the X11 display");
      if (!eglInitialize(display, nullptr, nullptr)) egl_fail("eglInitialize");
      egl_display = "X11";
    } else {
      open_headless(headless);
    }
    if (!eglBindAPI(EGL_OPENGL_ES_API)) egl_fail("binding GLES");
    const EGLint config_attribs[] = {EGL_SURFACE_TYPE,
                                     window ? EGL_WINDOW_BIT : EGL_PBUFFER_BIT,
                                     EGL_RENDERABLE_TYPE,
                                     EGL_OPENGL_ES3_BIT,
                                     EGL_RED_SIZE,
                                     8,
                                     EGL_GREEN_SIZE,
                                     8,
                                     EGL_BLUE_SIZE,
                                     8,
                                     EGL_ALPHA_SIZE,
                                     8,
                                     EGL_NONE};
    EGLConfig config = nullptr;
    EGLint count = 0;
    if (!eglChooseConfig(display, config_attribs, &config, 1, &count) || count < 1)
      egl_fail("finding a GLES 3 configuration");
    const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0,
                                      EGL_NONE};
    context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
    if (context == EGL_NO_CONTEXT) egl_fail("creating a GLES 3 context");
    if (window) {
      EGLint visual = 0;
      if (!eglGetConfigAttrib(display, config, EGL_NATIVE_VISUAL_ID, &visual))
        egl_fail("asking the configuration's X visual");
      window->create(static_cast<unsigned long>(visual), options->width, options->height,
                     options->title);
      surface = eglCreatePlatformWindowSurface(display, config, window->native_window(), nullptr);
      if (surface == EGL_NO_SURFACE) egl_fail("creating the window surface");
    }
    if (!eglMakeCurrent(display, surface, surface, context))
      egl_fail(window ? "making the context current on the window"
                      : "making the context current without a surface");
    // Two timestamps rather than one GL_TIME_ELAPSED_EXT query, whose result llvmpipe gets
    // wrong; 64-bit results, since timestamps do not fit 32 bits.
    if (has_extension("GL_EXT_disjoint_timer_query")) {
      query_counter =
          reinterpret_cast<PFNGLQUERYCOUNTEREXTPROC>(eglGetProcAddress("glQueryCounterEXT"));
      query_result_64 = reinterpret_cast<PFNGLGETQUERYOBJECTUI64VEXTPROC>(
          eglGetProcAddress("glGetQueryObjectui64vEXT"));
      if (query_counter && query_result_64) glGenQueries(2, stamps);
    }
    background = link(kFullScreenVs, kBackgroundFs, "background");
    object = link(kObjectVs, kObjectFs, "object");
    auto at = [](GLuint program, const char* name) { return glGetUniformLocation(program, name); };
    bg = {at(background, "u_depth"), at(background, "u_image"), at(background, "u_has_image"),
          at(background, "u_height"), at(background, "u_rev")};
    obj = {at(object, "u_proj"),        at(object, "u_depth"), at(object, "u_height"),
           at(object, "u_width"),       at(object, "u_rev"),   at(object, "u_cam"),
           at(object, "u_soft_radius"), at(object, "u_color"), at(object, "u_sphere"),
           at(object, "u_sphere_cr")};
    glGenVertexArrays(1, &vao_empty);
    glGenVertexArrays(1, &vao_box);
    glGenBuffers(1, &vbo_box);
    glBindVertexArray(vao_box);
    glBindBuffer(GL_ARRAY_BUFFER, vbo_box);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                          reinterpret_cast<const void*>(3 * sizeof(float)));
    glBindVertexArray(0);
    glGenTextures(1, &depth_tex);
    glGenTextures(1, &image_tex);
    for (GLuint t : {depth_tex, image_tex}) {
      glBindTexture(GL_TEXTURE_2D, t);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    }
    glGenFramebuffers(1, &fbo);
    glGenRenderbuffers(1, &color_rb);
    glGenRenderbuffers(1, &depth_rb);
    check_gl("creating GL objects");
  }

  // GL calls act on the thread's current context, which another renderer may have made its own.
  void make_current() {
    if (eglGetCurrentContext() != context && !eglMakeCurrent(display, surface, surface, context))
      egl_fail("making the renderer's context current");
  }

  void release() {
    if (display == EGL_NO_DISPLAY) return;
    if (context != EGL_NO_CONTEXT) {
      // The objects are deleted in this renderer's context only, never in another's that holds
      // the same names; destroying the context frees them too where it cannot be made current.
      if (eglGetCurrentContext() == context || eglMakeCurrent(display, surface, surface, context)) {
        glDeleteProgram(background);
        glDeleteProgram(object);
        glDeleteVertexArrays(1, &vao_empty);
        glDeleteVertexArrays(1, &vao_box);
        glDeleteBuffers(1, &vbo_box);
        glDeleteTextures(1, &depth_tex);
        glDeleteTextures(1, &image_tex);
        glDeleteFramebuffers(1, &fbo);
        glDeleteRenderbuffers(1, &color_rb);
        glDeleteRenderbuffers(1, &depth_rb);
        if (stamps[0]) glDeleteQueries(2, stamps);
        eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      }
      eglDestroyContext(display, context);
      context = EGL_NO_CONTEXT;
    }
    if (surface != EGL_NO_SURFACE) eglDestroySurface(display, surface);
    surface = EGL_NO_SURFACE;
    // An EGL display is one per process and platform display, shared with every other renderer
    // (and any other EGL user in it): terminating it would pull it from under them, so it lives
    // until exit, when Mesa tears it down (the X connection under it lives as long).
    eglReleaseThread();
    display = EGL_NO_DISPLAY;
    window.reset();
  }

  // The input textures at a frame's size. The framebuffer follows only once the frame is drawn
  // (resize_target): a frame given up after its upload leaves the last one drawn, whatever its
  // size.
  void resize_inputs(int w, int h) {
    if (w == input_width && h == input_height) return;
    GLint max_size = 0;
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
    if (w <= 0 || h <= 0 || w > max_size || h > max_size)
      throw Error("compositor: frame size " + std::to_string(w) + "x" + std::to_string(h) +
                  " is outside 1.." + std::to_string(max_size));
    glBindTexture(GL_TEXTURE_2D, depth_tex);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, w, h, 0, GL_RED, GL_FLOAT, nullptr);
    glBindTexture(GL_TEXTURE_2D, image_tex);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, w, h, 0, GL_RED, GL_UNSIGNED_BYTE, nullptr);
    check_gl("allocating the input textures");
    input_width = w;
    input_height = h;
  }

  void resize_target(int w, int h) {
    if (w == width && h == height) return;
    glBindRenderbuffer(GL_RENDERBUFFER, color_rb);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w, h);
    glBindRenderbuffer(GL_RENDERBUFFER, depth_rb);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, w, h);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_rb);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_rb);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error("GL: the offscreen framebuffer is incomplete");
    check_gl("allocating the framebuffer");
    width = w;
    height = h;
  }

  void upload(const RealFrame& f) {
    if (!f.depth) throw Error("compositor: a frame without depth");
    if (f.depth_stride % sizeof(float) != 0 ||
        f.depth_stride < static_cast<std::size_t>(f.camera.width) * sizeof(float))
      throw Error("compositor: depth rows of " + std::to_string(f.depth_stride) +
                  " bytes do not fit a width of " + std::to_string(f.camera.width));
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, depth_tex);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, static_cast<GLint>(f.depth_stride / sizeof(float)));
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, input_width, input_height, GL_RED, GL_FLOAT, f.depth);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, image_tex);
    if (f.image) {
      if (f.image_stride < static_cast<std::size_t>(f.camera.width))
        throw Error("compositor: image rows shorter than the width");
      glPixelStorei(GL_UNPACK_ROW_LENGTH, static_cast<GLint>(f.image_stride));
      glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, input_width, input_height, GL_RED, GL_UNSIGNED_BYTE,
                      f.image);
    }
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    check_gl("uploading depth and image");
  }
};

Renderer::Renderer() : impl_(std::make_unique<Impl>(nullptr)) {}
Renderer::Renderer(HeadlessDisplay headless) : impl_(std::make_unique<Impl>(nullptr, headless)) {}
Renderer::Renderer(const WindowOptions& window) : impl_(std::make_unique<Impl>(&window)) {}
Renderer::~Renderer() = default;

const std::string& Renderer::egl_display() const {
  return impl_->egl_display;
}

HeadlessDisplay parse_headless_display(const std::string& name) {
  if (name == "auto") return HeadlessDisplay::kAuto;
  if (name == "surfaceless") return HeadlessDisplay::kSurfaceless;
  if (name == "device") return HeadlessDisplay::kDevice;
  throw Error("--egl takes auto, surfaceless or device, not '" + printable(name) + "'");
}

const char* Renderer::gl_renderer() const {
  impl_->make_current();
  return reinterpret_cast<const char*>(glGetString(GL_RENDERER));
}

RenderTimes Renderer::render(const RealFrame& frame, const Scene& scene,
                             const RenderOptions& options, const std::function<bool()>& keep) {
  Impl& m = *impl_;
  m.make_current();
  const Camera& cam = frame.camera;
  if (!(cam.fx > 0 && cam.fy > 0 && std::isfinite(cam.cx) && std::isfinite(cam.cy)))
    throw Error("compositor: the frame carries no usable camera intrinsics");
  if (options.soft_radius_px < 0 || options.soft_radius_px > 8)
    throw Error("compositor: soft radius must be 0..8 px");
  if (!(options.near_m > 0 && options.far_m > options.near_m))
    throw Error("compositor: the depth range needs 0 < near < far (far may be infinite)");
  const auto start = std::chrono::steady_clock::now();
  if (m.stamps[0]) {
    GLint disjoint = 0;
    glGetIntegerv(GL_GPU_DISJOINT_EXT, &disjoint);  // clears the flag before the measurement
    m.query_counter(m.stamps[0], GL_TIMESTAMP_EXT);
  }
  m.resize_inputs(cam.width, cam.height);
  m.upload(frame);
  if (keep && !keep()) {
    RenderTimes skipped;
    skipped.drawn = false;
    return skipped;
  }
  m.resize_target(cam.width, cam.height);

  const double n = options.near_m, f = options.far_m;
  // OpenGL's projection of z to NDC, a + b / z; with no far plane its limit, 1 - 2n / z. It clips;
  // the depth test reads the reversed window depth rev_a + rev_b / z instead (1 at the near
  // plane, 0 at the far one; n / z without a far plane), which a float keeps to a relative 1e-7
  // at any distance, where 1 - n / z rounds to 1 beyond some 100 km.
  const float a = std::isinf(f) ? 1.0f : static_cast<float>((f + n) / (f - n));
  const float b =
      std::isinf(f) ? static_cast<float>(-2 * n) : static_cast<float>(-2 * f * n / (f - n));
  const float rev_a = std::isinf(f) ? 0.0f : static_cast<float>(-n / (f - n));
  const float rev_b = std::isinf(f) ? static_cast<float>(n) : static_cast<float>(f * n / (f - n));
  const double w = cam.width, h = cam.height;
  // Column-major: pixel centres of the depth map land on pixel centres of the framebuffer, row 0
  // of the image at the top.
  const float proj[16] = {static_cast<float>(2 * cam.fx / w),
                          0,
                          0,
                          0,
                          0,
                          static_cast<float>(-2 * cam.fy / h),
                          0,
                          0,
                          static_cast<float>(2 * (cam.cx + 0.5) / w - 1),
                          static_cast<float>(1 - 2 * (cam.cy + 0.5) / h),
                          a,
                          1,
                          0,
                          0,
                          b,
                          0};

  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glViewport(0, 0, cam.width, cam.height);
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_ALWAYS);
  glClearDepthf(0.0f);  // reversed: 0 is infinitely far
  glClearColor(0, 0, 0, 0);
  glDepthMask(GL_TRUE);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  // Soft occlusion compares against real depth in the object shader, so the depth buffer keeps
  // only the objects' own depth there.
  glDepthMask(options.soft_radius_px == 0 ? GL_TRUE : GL_FALSE);
  glUseProgram(m.background);
  glUniform1i(m.bg.depth, 0);
  glUniform1i(m.bg.image, 1);
  glUniform1i(m.bg.has_image, frame.image ? 1 : 0);
  glUniform1i(m.bg.height, cam.height);
  glUniform2f(m.bg.rev, rev_a, rev_b);
  glBindVertexArray(m.vao_empty);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  check_gl("drawing the camera image and real depth");

  if (!scene.empty()) {
    m.boxes.clear();
    for (const Cube& c : scene.cubes)
      m.boxes.insert(m.boxes.end(), {c.center[0], c.center[1], c.center[2], c.size / 2});
    for (const Sphere& s : scene.spheres)
      m.boxes.insert(m.boxes.end(), {s.center[0], s.center[1], s.center[2], s.radius});
    glBindVertexArray(m.vao_box);
    glBindBuffer(GL_ARRAY_BUFFER, m.vbo_box);
    if (m.boxes != m.uploaded_boxes) {
      m.vertices.clear();
      for (std::size_t i = 0; i < m.boxes.size(); i += 4)
        append_box(m.vertices, {m.boxes[i], m.boxes[i + 1], m.boxes[i + 2]}, m.boxes[i + 3]);
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(m.vertices.size() * sizeof(float)),
                   m.vertices.data(), GL_DYNAMIC_DRAW);
      check_gl("uploading the objects");
      m.uploaded_boxes = m.boxes;
    }
    glDepthFunc(GL_GREATER);
    glDepthMask(GL_TRUE);
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(GL_CCW);
    glEnable(GL_BLEND);
    // Colour blends by coverage; alpha accumulates coverage over the camera's 0.
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(m.object);
    glUniformMatrix4fv(m.obj.proj, 1, GL_FALSE, proj);
    glUniform1i(m.obj.depth, 0);
    glUniform1i(m.obj.height, cam.height);
    glUniform1i(m.obj.width, cam.width);
    glUniform2f(m.obj.rev, rev_a, rev_b);
    glUniform4f(m.obj.cam, static_cast<float>(cam.fx), static_cast<float>(cam.fy),
                static_cast<float>(cam.cx), static_cast<float>(cam.cy));
    glUniform1i(m.obj.soft_radius, options.soft_radius_px);
    const GLint color = m.obj.color, is_sphere = m.obj.sphere, sphere_cr = m.obj.sphere_cr;
    GLint first = 0;
    for (const Cube& c : scene.cubes) {
      glUniform3f(color, c.color[0], c.color[1], c.color[2]);
      glUniform1i(is_sphere, 0);
      glDrawArrays(GL_TRIANGLES, first, 36);
      first += 36;
    }
    for (const Sphere& s : scene.spheres) {
      glUniform3f(color, s.color[0], s.color[1], s.color[2]);
      glUniform1i(is_sphere, 1);
      glUniform4f(sphere_cr, s.center[0], s.center[1], s.center[2], s.radius);
      glDrawArrays(GL_TRIANGLES, first, 36);
      first += 36;
    }
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    glBindVertexArray(0);
    check_gl("drawing the virtual objects");
  }
  if (m.stamps[0]) m.query_counter(m.stamps[1], GL_TIMESTAMP_EXT);
  glFinish();
  RenderTimes times;
  times.wall_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (m.stamps[0]) {
    GLuint64 begin = 0, end = 0;
    GLint disjoint = 0;
    m.query_result_64(m.stamps[0], GL_QUERY_RESULT, &begin);
    m.query_result_64(m.stamps[1], GL_QUERY_RESULT, &end);
    glGetIntegerv(GL_GPU_DISJOINT_EXT, &disjoint);
    // A disjoint event (clock change, reset) makes the interval meaningless.
    if (!disjoint && end >= begin) times.gpu_ms = static_cast<double>(end - begin) / 1e6;
  }
  check_gl("finishing the frame");
  return times;
}

bool Renderer::windowed() const {
  return impl_->window != nullptr;
}

unsigned long Renderer::window_id() const {
  return impl_->window ? impl_->window->window_id() : 0;
}

bool Renderer::present() {
  Impl& m = *impl_;
  if (!m.window || !m.window->poll()) return false;
  m.make_current();
  const int ww = m.window->width(), wh = m.window->height();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, ww, wh);
  glClearColor(0, 0, 0, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  if (m.width > 0 && m.height > 0) {
    // The largest rectangle of the frame's aspect that fits, centred. The offscreen framebuffer
    // already holds the image's top row at GL's top, as the window wants it.
    const double scale =
        std::min(static_cast<double>(ww) / m.width, static_cast<double>(wh) / m.height);
    const int dw = static_cast<int>(std::lround(m.width * scale));
    const int dh = static_cast<int>(std::lround(m.height * scale));
    const int x0 = (ww - dw) / 2, y0 = (wh - dh) / 2;
    glBindFramebuffer(GL_READ_FRAMEBUFFER, m.fbo);
    glBlitFramebuffer(0, 0, m.width, m.height, x0, y0, x0 + dw, y0 + dh, GL_COLOR_BUFFER_BIT,
                      dw == m.width && dh == m.height ? GL_NEAREST : GL_LINEAR);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  }
  check_gl("showing the frame in the window");
  if (!eglSwapBuffers(m.display, m.surface)) egl_fail("eglSwapBuffers");
  return true;
}

const std::vector<std::uint8_t>& Renderer::read_rgba() {
  Impl& m = *impl_;
  m.make_current();
  const std::size_t row = static_cast<std::size_t>(m.width) * 4;
  m.flipped.resize(row * static_cast<std::size_t>(m.height));
  m.rgba.resize(m.flipped.size());
  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, m.width, m.height, GL_RGBA, GL_UNSIGNED_BYTE, m.flipped.data());
  check_gl("reading the framebuffer");
  for (int y = 0; y < m.height; ++y)
    std::copy_n(m.flipped.data() + static_cast<std::size_t>(m.height - 1 - y) * row, row,
                m.rgba.data() + static_cast<std::size_t>(y) * row);
  return m.rgba;
}

}  // namespace dco::compositor
