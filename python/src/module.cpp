// penumbra._penumbra: the C++ library seen from Python (nanobind). The public
// API, with its annotations and documentation, is python/penumbra/__init__.py,
// which calls these; Image is exposed as it is.
//
// Threads: every call that renders releases the GIL; the progress hook takes it
// back (at most every 20 ms, between tiles or launches) to run PyErr_CheckSignals()
// on the calling thread, so that Ctrl-C stops a render with KeyboardInterrupt,
// and the caller's progress function. Errors: SceneError and BackendError
// (python/penumbra/_errors.py), raised by the translator below.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>
#include <nanobind/stl/pair.h>

#include "io/image.h"
#include "render/compare.h"
#include "render/converge.h"
#include "session.h"
#if PN_HAVE_OPTIX
#include "backends/optix/optix_backend.h"
#include "device_image.h"
#endif

#ifndef PENUMBRA_GIT_COMMIT
#define PENUMBRA_GIT_COMMIT "unknown"
#endif

namespace nb = nanobind;
using namespace nb::literals;
using json = nlohmann::json;

namespace pn::py {
namespace {

// A failure of a backend (no GPU or driver, a CUDA or Embree error, a failed build):
// raised in Python as penumbra.BackendError.
struct BackendFailure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Runs `f` with the GIL released; std::runtime_errors other than scene errors
// come back as BackendFailure (std::invalid_argument becomes a ValueError).
template <class F>
auto backend_call(F&& f) {
  try {
    nb::gil_scoped_release release;
    return f();
  } catch (const SceneError&) {
    throw;
  } catch (const nb::python_error&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw BackendFailure(e.what());
  } catch (const std::bad_alloc&) {
    throw BackendFailure("out of memory");
  }
}

// The progress hook of a render started by the calling thread (which holds the
// GIL now): Ctrl-C, and the caller's callback(done, total) when given.
// (The function, and the Python object in it, are destroyed by the binding that
// made it, with the GIL held: backends take it by reference and copy it nowhere.)
ProgressFn python_progress(nb::object callback) {
  const auto caller = std::this_thread::get_id();
  auto last = std::make_shared<std::chrono::steady_clock::time_point>(std::chrono::steady_clock::now());
  const bool has_callback = callback.is_valid() && !callback.is_none();
  return [caller, last, callback, has_callback](uint64_t done, uint64_t total) {
    // Python runs signal handlers on the main thread only: check where the
    // render was started. The callback runs on whichever thread reports
    // (calls are serialised), so that it sees the last one too.
    const bool on_caller = std::this_thread::get_id() == caller;
    if (!on_caller && !has_callback) return;
    auto now = std::chrono::steady_clock::now();
    if (done < total && now - *last < std::chrono::milliseconds(20)) return;
    *last = now;
    nb::gil_scoped_acquire gil;
    if (on_caller && PyErr_CheckSignals() != 0) throw nb::python_error();
    if (has_callback) callback(done, total);
  };
}

nb::object to_py(const json& j) {
  switch (j.type()) {
    case json::value_t::null: return nb::none();
    case json::value_t::boolean: return nb::bool_(j.get<bool>());
    case json::value_t::number_integer: return nb::int_(j.get<int64_t>());
    case json::value_t::number_unsigned: return nb::int_(j.get<uint64_t>());
    case json::value_t::number_float: return nb::float_(j.get<double>());
    case json::value_t::string: return nb::str(j.get_ref<const std::string&>().c_str());
    case json::value_t::array: {
      nb::list l;
      for (const auto& v : j) l.append(to_py(v));
      return l;
    }
    case json::value_t::object: {
      nb::dict d;
      for (auto it = j.begin(); it != j.end(); ++it) d[it.key().c_str()] = to_py(it.value());
      return d;
    }
    default: return nb::none();
  }
}

json parse_json_text(const std::string& text, const std::string& source) {
  try {
    return json::parse(text);
  } catch (const json::exception& e) {
    throw SceneError(source, "", std::string("invalid JSON: ") + e.what());
  }
}

// What Python holds for penumbra.Image.
struct PyImage {
  std::shared_ptr<ImageData> data;
};
struct PyScene {
  SceneState state;
};

// A (H, W, 3) float32 array of `data`, owned by `owner`, on the CPU or the GPU:
// a Python object with __dlpack__ and __dlpack_device__ (the array API's exchange).
using DlpackArray = nb::ndarray<nb::array_api>;
DlpackArray image_array(const float* data, const ImageData& img, nb::handle owner, int device_type, int device_id) {
  size_t shape[3] = {size_t(img.height), size_t(img.width), 3};
  return DlpackArray(const_cast<float*>(data), 3, shape, owner, nullptr, nb::dtype<float>(), device_type, device_id);
}

// The mean or the variance as a read-only numpy view owned by the Image (GPU
// results are copied to the host once, on first use).
using HostArray = nb::ndarray<nb::numpy, const float, nb::shape<-1, -1, 3>, nb::c_contig>;
HostArray host_view(PyImage& self, bool variance) {
  ImageData& img = *self.data;
  const float* data = backend_call([&] { return variance ? img.variance() : img.rgb(); });
  size_t shape[3] = {size_t(img.height), size_t(img.width), 3};
  return HostArray(data, 3, shape, nb::find(&self));
}

// The denoised image or a guide (a read-only numpy view), or None without denoising.
nb::object denoise_view(PyImage& self, const std::vector<float>& v) {
  const ImageData& img = *self.data;
  if (v.empty()) return nb::none();
  size_t shape[3] = {size_t(img.height), size_t(img.width), 3};
  return nb::cast(HostArray(v.data(), 3, shape, nb::find(&self)));
}

DlpackArray dlpack_of(PyImage& self, bool variance) {
  ImageData& img = *self.data;
  nb::handle owner = nb::find(&self);
#if PN_HAVE_OPTIX
  if (img.device)
    return image_array(variance ? img.device->variance() : img.device->rgb(), img, owner, nb::device::cuda::value,
                       img.device->device());
#endif
  const float* p = variance ? img.variance() : img.rgb();
  return image_array(p, img, owner, nb::device::cpu::value, 0);
}

void raise_scene_error(const SceneError& e) {
  nb::object cls = nb::module_::import_("penumbra._errors").attr("SceneError");
  nb::object file = e.file().empty() ? nb::none() : nb::object(nb::str(e.file().c_str()));
  std::string f = e.field();
  if (f.rfind("--set ", 0) == 0) f = f.substr(6, f.find('=') == std::string::npos ? std::string::npos : f.find('=') - 6);
  nb::object field = f.empty() ? nb::none() : nb::object(nb::str(f.c_str()));
  nb::object exc = cls(nb::str(e.what()), file, field);
  PyErr_SetObject(cls.ptr(), exc.ptr());
}

void raise_backend_error(const std::string& what) {
  nb::object cls = nb::module_::import_("penumbra._errors").attr("BackendError");
  PyErr_SetString(cls.ptr(), what.c_str());
}

}  // namespace
}  // namespace pn::py

NB_MODULE(_penumbra, m) {
  using namespace pn;
  using namespace pn::py;
  m.doc() = "penumbra's C++ library (see the package penumbra for the documented API)";

  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const SceneError& e) {
      raise_scene_error(e);
    } catch (const BackendFailure& e) {
      raise_backend_error(e.what());
    }
  });

  m.def("scenes", []() {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& s : builtin_scenes()) out.emplace_back(s.name, s.description);
    return out;
  });

  m.def("build_info", []() {
    json info;
    info["git_commit"] = PENUMBRA_GIT_COMMIT;
#if PN_HAVE_OPTIX
    info["optix"] = true;
    std::string why;
    info["gpu_available"] = optix_available(&why);
    info["gpu_unavailable_reason"] = why;
    info["gpus"] = optix_device_count();
#else
    info["optix"] = false;
    info["gpu_available"] = false;
    info["gpu_unavailable_reason"] = "built without the OptiX backend";
    info["gpus"] = 0;
#endif
    info["strategies"] = json::array();
    for (int i = 0; i < kNumStrategies; ++i) info["strategies"].push_back(strategy_name(Strategy(i)));
    return to_py(info);
  });

  // --- Scenes ---------------------------------------------------------------------
  nb::class_<PyScene>(m, "Scene")
      .def_prop_ro("source", [](const PyScene& s) { return s.state.source; })
      .def("to_py", [](const PyScene& s) { return to_py(s.state.doc); })
      .def("with_overrides",
           [](const PyScene& s, const std::vector<std::string>& overrides) {
             return PyScene{backend_call([&] { return scene_with_overrides(s.state, overrides); })};
           })
      .def("counts", [](const PyScene& s) {
        const Scene& sc = *s.state.scene;
        json c = {{"triangles", sc.triangle_count()}, {"spheres", sc.spheres.size()},
                  {"lights", sc.lights.size()},      {"materials", sc.materials.size() - 1},
                  {"meshes", sc.meshes.size()},       {"instances", sc.instances.size()},
                  {"textures", sc.textures.size()}};
        return to_py(c);
      });
  m.def("load_scene_name", [](const std::string& name, const std::vector<std::string>& overrides) {
    return PyScene{backend_call([&] { return scene_from_name(name, overrides); })};
  });
  m.def("load_scene_json",
        [](const std::string& text, const std::string& source, const std::string& base_dir,
           const std::vector<std::string>& overrides) {
          return PyScene{backend_call([&] {
            return scene_from_json(parse_json_text(text, source), source, base_dir, overrides);
          })};
        });

  // --- Images ------------------------------------------------------------------------
  nb::class_<PyImage>(m, "Image", R"(A rendered image: a snapshot of the accumulation.

Attributes:
    rgb: the per-pixel mean radiance, linear RGB, float32, shape (height, width, 3),
        row 0 at the top; a read-only numpy view of the image's buffer (no copy).
    variance: the per-pixel variance of that mean (squared standard error), alike.
    stats: a dict: backend, device, spp, strategy, times, rays, ...
    width, height, spp: the image size and samples per pixel.

Results of the GPU backend stay on the GPU until rgb or variance is read; use
rgb_dlpack() (or pass the image to torch.from_dlpack / cupy.from_dlpack) to use
them without a copy to the host.)")
      .def("__repr__",
           [](const PyImage& i) {
             const ImageData& d = *i.data;
             return "<penumbra.Image " + std::to_string(d.width) + "x" + std::to_string(d.height) + ", " +
                    std::to_string(d.spp) + " spp, " + d.stats.value("backend", std::string("?")) +
                    (d.device ? ", on the GPU>" : ">");
           })
      .def_prop_ro("width", [](const PyImage& i) { return i.data->width; })
      .def_prop_ro("height", [](const PyImage& i) { return i.data->height; })
      .def_prop_ro("spp", [](const PyImage& i) { return i.data->spp; })
      .def_prop_ro("stats", [](const PyImage& i) { return to_py(i.data->stats); })
      .def_prop_ro("on_gpu", [](const PyImage& i) { return bool(i.data->device); },
                   "True when the image is held on the GPU (the OptiX backend)")
      .def_prop_ro("rgb", [](PyImage& i) { return host_view(i, false); }, "Mean radiance, float32 (H, W, 3), read-only")
      .def_prop_ro("variance", [](PyImage& i) { return host_view(i, true); },
                   "Variance of the mean, float32 (H, W, 3), read-only")
      .def_prop_ro("denoised", [](PyImage& i) { return denoise_view(i, i.data->denoised); },
                   "The mean denoised by the OptiX AI denoiser, float32 (H, W, 3), read-only; None unless denoised")
      .def_prop_ro("albedo", [](PyImage& i) { return denoise_view(i, i.data->albedo); },
                   "The denoiser's albedo guide, float32 (H, W, 3) in [0, 1]; None unless denoised")
      .def_prop_ro("normal", [](PyImage& i) { return denoise_view(i, i.data->normal); },
                   "The denoiser's normal guide: unit world-space normals (0 where rays escaped); None unless denoised")
      .def(
          "rgb_dlpack", [](PyImage& i) { return dlpack_of(i, false); },
          "The mean as a DLPack-capable array, float32 (H, W, 3), without a copy: on the GPU for GPU results, "
          "else on the host. torch.from_dlpack(image.rgb_dlpack()) or cupy.from_dlpack(...) take it.")
      .def(
          "variance_dlpack", [](PyImage& i) { return dlpack_of(i, true); },
          "The variance of the mean as a DLPack-capable array (see rgb_dlpack)")
      .def(
          "__dlpack__",
          [](PyImage& i, nb::kwargs kwargs) -> nb::object {
            return nb::cast(dlpack_of(i, false)).attr("__dlpack__")(**kwargs);
          },
          "DLPack export of rgb (see rgb_dlpack)")
      .def("__dlpack_device__",
           [](PyImage& i) {
             (void)i;
#if PN_HAVE_OPTIX
             if (i.data->device) return std::make_pair(int(nb::device::cuda::value), i.data->device->device());
#endif
             return std::make_pair(int(nb::device::cpu::value), 0);
           })
      .def(
          "save",
          [](PyImage& i, const std::filesystem::path& path, float exposure,
             const std::optional<std::filesystem::path>& variance_path) {
            ImageData& img = *i.data;
            std::vector<float> rgb, var;
            backend_call([&] {
              rgb.assign(img.rgb(), img.rgb() + img.count());
              if (variance_path) var.assign(img.variance(), img.variance() + img.count());
              return 0;
            });
            try {
              nb::gil_scoped_release release;
              write_image(path.string(), img.width, img.height, rgb, exposure);
              if (variance_path) write_image(variance_path->string(), img.width, img.height, var);
            } catch (const std::runtime_error& e) {
              PyErr_SetString(PyExc_OSError, e.what());
              throw nb::python_error();
            }
          },
          "path"_a, "exposure"_a = 0.f, "variance_path"_a = nb::none(),
          "Writes the image as penumbra render does: .exr linear float32, .png sRGB 8-bit after `exposure` "
          "stops; with variance_path, also the variance (EXR)");

  // --- Renderer ------------------------------------------------------------------------
  nb::class_<Renderer>(m, "Renderer")
      .def(
          "__init__",
          [](Renderer* self, const PyScene& scene, const std::string& backend, int threads, const std::string& gpus,
             const std::vector<std::string>& overrides) {
            backend_call([&] {
              new (self) Renderer(scene.state, backend, threads, gpus, overrides);
              return 0;
            });
          },
          "scene"_a, "backend"_a, "threads"_a, "gpus"_a, "overrides"_a)
      .def("update",
           [](Renderer& r, const std::vector<std::string>& overrides) {
             backend_call([&] {
               r.update(overrides);
               return 0;
             });
           })
      .def(
          "render",
          [](Renderer& r, uint32_t spp, nb::object progress) {
            ProgressFn fn = python_progress(std::move(progress));
            backend_call([&] {
              r.render(spp, fn);
              return 0;
            });
          },
          "spp"_a, "progress"_a.none() = nb::none())
      .def(
          "image", [](Renderer& r, bool denoise) { return PyImage{backend_call([&] { return r.image(denoise); })}; },
          "denoise"_a = false)
      .def("reset",
           [](Renderer& r) {
             backend_call([&] {
               r.reset();
               return 0;
             });
           })
      .def_prop_ro("samples", [](Renderer& r) { return backend_call([&] { return r.samples(); }); })
      .def_prop_ro("backend", [](Renderer& r) { return r.backend_name(); })
      .def_prop_ro("device", [](Renderer& r) { return r.device_name(); })
      .def_prop_ro("note", [](Renderer& r) { return r.note(); })
      .def_prop_ro("builds", [](Renderer& r) { return r.builds(); })
      .def_prop_ro("scene", [](Renderer& r) { return PyScene{r.scene()}; })
      .def_prop_ro("settings", [](Renderer& r) {
        const RenderSettings& s = r.settings();
        json j = {{"width", s.width}, {"height", s.height}, {"spp", s.spp},        {"max_depth", s.max_depth},
                  {"rr_depth", s.rr_depth}, {"strategy", strategy_name(s.strategy)}, {"mis", mis_name(s.mis)},
                  {"light_selection", light_selection_name(s.light_selection)}, {"seed", s.seed}};
        return to_py(j);
      });

  // --- Files, comparison, convergence ------------------------------------------------------
  m.def("read_exr", [](const std::string& path) {
    int w = 0, h = 0;
    std::vector<float> v;
    try {
      v = read_exr(path, &w, &h);
    } catch (const std::runtime_error& e) {
      PyErr_SetString(PyExc_OSError, e.what());
      throw nb::python_error();
    }
    auto* data = new std::vector<float>(std::move(v));
    nb::capsule owner(data, [](void* p) noexcept { delete static_cast<std::vector<float>*>(p); });
    size_t shape[3] = {size_t(h), size_t(w), 3};
    return nb::ndarray<nb::numpy, float, nb::shape<-1, -1, 3>>(data->data(), 3, shape, owner);
  });

  using CArray = nb::ndarray<const float, nb::c_contig, nb::device::cpu>;
  m.def(
      "compare",
      [](CArray a, CArray a_var, CArray b, CArray b_var, double max_mean_rel_diff, double max_image_z,
         double outlier_z, double max_outlier_fraction) {
        size_t n = a.size();
        if (a_var.size() != n || b.size() != n || b_var.size() != n)
          throw std::invalid_argument("compare: the four arrays must have the same size");
        std::vector<float> va(a.data(), a.data() + n), vav(a_var.data(), a_var.data() + n), vb(b.data(), b.data() + n),
            vbv(b_var.data(), b_var.data() + n);
        CompareOptions o;
        o.max_mean_rel_diff = max_mean_rel_diff;
        o.max_image_z = max_image_z;
        o.outlier_z = outlier_z;
        o.max_outlier_fraction = max_outlier_fraction;
        CompareResult r = compare_images(va, vav, vb, vbv, o);
        json j = {{"pass", r.pass},
                  {"mean_a", r.mean_a},
                  {"mean_b", r.mean_b},
                  {"mean_rel_diff", r.mean_rel_diff},
                  {"image_z", r.image_z},
                  {"mean_z2", r.mean_z2},
                  {"max_abs_z", r.max_abs_z},
                  {"outliers", r.outliers},
                  {"channels", r.channels},
                  {"zero_var_mismatches", r.zero_var_mismatches},
                  {"summary", r.summary()}};
        return to_py(j);
      },
      "a"_a, "a_var"_a, "b"_a, "b_var"_a, "max_mean_rel_diff"_a, "max_image_z"_a, "outlier_z"_a,
      "max_outlier_fraction"_a);

  // Convergence experiments: the options (render/converge.h) as an object that
  // penumbra.converge() and the reference functions fill in.
  nb::class_<ConvergeOptions>(m, "ConvergeOptions")
      .def(nb::init<>())
      .def_rw("scene", &ConvergeOptions::scene)
      .def_rw("sets", &ConvergeOptions::sets)
      .def_rw("out", &ConvergeOptions::out)
      .def_rw("cache", &ConvergeOptions::cache)
      .def_rw("backend", &ConvergeOptions::backend)
      .def_rw("gpus", &ConvergeOptions::gpus)
      .def_rw("strategies", &ConvergeOptions::strategies)
      .def_rw("mis", &ConvergeOptions::mis)
      .def_rw("reference_strategy", &ConvergeOptions::reference_strategy)
      .def_rw("reference_mis", &ConvergeOptions::reference_mis)
      .def_rw("width", &ConvergeOptions::width)
      .def_rw("height", &ConvergeOptions::height)
      .def_rw("max_spp", &ConvergeOptions::max_spp)
      .def_rw("seeds", &ConvergeOptions::seeds)
      .def_rw("reference_spp", &ConvergeOptions::reference_spp)
      .def_rw("reference_chunk", &ConvergeOptions::reference_chunk)
      .def_rw("crop_spp", &ConvergeOptions::crop_spp)
      .def_rw("fit_min_spp", &ConvergeOptions::fit_min_spp)
      .def_rw("threads", &ConvergeOptions::threads)
      .def_rw("threshold", &ConvergeOptions::threshold)
      .def_rw("crop", &ConvergeOptions::crop)
      .def_rw("verbose", &ConvergeOptions::verbose)
      .def_rw("yes", &ConvergeOptions::yes)
      .def_rw("estimate_only", &ConvergeOptions::estimate_only);

  m.def(
      "converge",
      [](ConvergeOptions o, nb::object progress) {
        o.progress = python_progress(std::move(progress));
        ConvergeResult r = backend_call([&] { return run_converge(o); });
        nb::list rows;
        for (const ConvergeMeasurement& x : r.measurements) {
          nb::dict d;
          d["scene"] = o.scene;
          d["strategy"] = x.strategy;
          d["spp"] = x.spp;
          d["seed"] = x.seed;
          d["time_ms"] = x.time_ms;
          d["rmse"] = x.rmse;
          d["rmse_nolight"] = x.rmse_nolight;
          d["relmse"] = x.relmse;
          d["relmse_nolight"] = x.relmse_nolight;
          rows.append(d);
        }
        return nb::make_tuple(rows, to_py(r.summary));
      },
      "options"_a, "progress"_a.none());

  m.def("converge_plan", [](const ConvergeOptions& o) {
    ConvergePlan p = backend_call([&] { return plan_converge(o); });
    const ReferencePlan& r = p.reference;
    json techniques = json::array();
    for (size_t i = 0; i < p.techniques.size(); ++i)
      techniques.push_back({{"name", p.techniques[i]}, {"strategy", p.technique_parts[i].first},
                            {"mis", p.technique_parts[i].second}});
    json j = {{"reference", {{"key", r.key}, {"path", r.path}, {"var_path", r.var_path}, {"width", r.width},
                             {"height", r.height}, {"spp", r.spp}, {"chunk_spp", r.chunk_spp}, {"chunks", r.chunks},
                             {"cached", r.cached}}},
              {"techniques", techniques}};
    return to_py(j);
  });

  // A film's sums as two float64 numpy arrays (H, W, 3) that own a copy.
  using SumsArray = nb::ndarray<nb::numpy, double, nb::shape<-1, -1, 3>>;
  m.def(
      "render_reference_chunk",
      [](ConvergeOptions o, int index, nb::object progress) {
        o.progress = python_progress(std::move(progress));
        ReferenceChunk chunk = backend_call([&] { return render_reference_chunk(o, index); });
        const Film& film = chunk.film;
        auto array = [&](const double* data) {
          auto* v = new std::vector<double>(data, data + film.pixel_count() * 3);
          nb::capsule owner(v, [](void* p) noexcept { delete static_cast<std::vector<double>*>(p); });
          size_t shape[3] = {size_t(film.height()), size_t(film.width()), 3};
          return SumsArray(v->data(), 3, shape, owner);
        };
        return nb::make_tuple(array(film.sum()), array(film.sum_sq()), film.samples(), chunk.nonfinite);
      },
      "options"_a, "index"_a, "progress"_a.none());

  using CSums = nb::ndarray<const double, nb::shape<-1, -1, 3>, nb::c_contig, nb::device::cpu>;
  m.def(
      "store_reference",
      [](const ConvergeOptions& o, CSums sum, CSums sum_sq, uint64_t samples) {
        if (sum.shape(0) != sum_sq.shape(0) || sum.shape(1) != sum_sq.shape(1))
          throw std::invalid_argument("store_reference: sums and sums of squares differ in shape");
        Film film(int(sum.shape(1)), int(sum.shape(0)));
        std::copy(sum.data(), sum.data() + sum.size(), film.sum());
        std::copy(sum_sq.data(), sum_sq.data() + sum_sq.size(), film.sum_sq());
        film.add_samples(samples);
        backend_call([&] {
          store_reference(o, film);
          return 0;
        });
      },
      "options"_a, "sum"_a, "sum_sq"_a, "samples"_a);
}
