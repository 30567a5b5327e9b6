// The viewer's Dear ImGui panel and the overlay on the image (viewer_state.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <imgui.h>
#include <imgui_stdlib.h>

#include "apps/viewer/viewer_state.h"

namespace pn::viewer {

namespace {

// A combo box over one of the registries' enums, listed by their names.
template <class E>
void enum_combo(const char* label, E* value, int count, const char* (*name)(E)) {
  struct Names {
    const char* (*name)(E);
  } names{name};
  int i = int(*value);
  if (ImGui::Combo(
          label, &i,
          [](void* data, int k, const char** out) {
            *out = static_cast<Names*>(data)->name(E(k));
            return true;
          },
          &names, count))
    *value = E(i);
}

// ImGui's widgets on the settings' own fields: a 0/1 flag, a count clamped to
// [lo, most] (typed values may leave the slider's range).
void flag_checkbox(const char* label, uint32_t* flag) {
  bool b = *flag != 0;
  if (ImGui::Checkbox(label, &b)) *flag = b ? 1u : 0u;
}
void count_slider(const char* label, uint32_t* count, int lo, int hi, int most, ImGuiSliderFlags flags = 0) {
  int v = int(*count);
  ImGui::SliderInt(label, &v, lo, hi, "%d", flags);
  *count = uint32_t(std::clamp(v, lo, most));
}

}  // namespace

void Viewer::draw_panel() {
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(330, 0), ImGuiCond_FirstUseEver);
  if (!ImGui::Begin("penumbra (Tab hides)")) {
    ImGui::End();
    return;
  }
  ImGui::Text("%s", scene_->source.c_str());
  ImGui::TextWrapped("%s: %s", backend_->name().c_str(), backend_->device_name().c_str());
  ImGui::Text("image %dx%d, display: %s", applied_.width, applied_.height, display_path_name(display_path_.path));
  if (display_path_.path != DisplayPath::Interop && backend_->name() == "optix")
    ImGui::TextWrapped("%s", display_path_.note.c_str());  // why not interop

  // Timing: ms/frame and fps as displayed, with a rolling graph.
  double avg = recent_ms_.empty() ? 0.0
                                  : std::accumulate(recent_ms_.begin(), recent_ms_.end(), 0.0) / recent_ms_.size();
  char overlay[64];
  std::snprintf(overlay, sizeof overlay, "%.1f ms/frame  %.1f fps", avg, avg > 0 ? 1000.0 / avg : 0.0);
  ImGui::PlotLines("##frame", recent_ms_.data(), int(recent_ms_.size()), 0, overlay, 0.f,
                   float(std::max(1.0, 2.0 * avg)), ImVec2(ImGui::GetContentRegionAvail().x, 48));
  ImGui::Text("render %.1f ms/frame, %.1f s since restart", last_render_ms_,
              std::chrono::duration<double>(Clock::now() - restart_time_).count());
  for (const Side& s : sides_)
    ImGui::Text("%s%-11s %5llu spp %6.3g us/px", sides_.size() > 1 ? (&s == &sides_[0] ? "left  " : "right ") : "",
                strategy_name(s.strategy), (unsigned long long)s.image->samples(), s.seconds_per_pixel() * 1e6);

  auto strategy_combo = [](const char* label, Strategy* s) {
    int i = int(*s);
    bool changed = ImGui::Combo(
        label, &i,
        [](void*, int k, const char** out) {
          static char names[kNumStrategies][32];
          std::snprintf(names[k], sizeof names[k], "%d: %s", k + 1, strategy_name(Strategy(k)));
          *out = names[k];
          return true;
        },
        nullptr, kNumStrategies);
    if (changed) *s = Strategy(i);
  };
  ImGui::Separator();
  IntegratorSettings& in = integrator_;
  if (!split_) strategy_combo("strategy", &in.strategy);
  enum_combo("MIS", &in.mis, kNumMisModes, mis_name);
  // How the light of each sample is chosen (restir with the scene's
  // render.restir settings; temporal reuse between frames as the panel says).
  enum_combo("light selection", &in.light_selection, kNumLightSelections, light_selection_name);
  if (in.light_selection == LightSelection::Restir) {
    RestirSettings& r = in.restir;
    flag_checkbox("temporal reuse", &r.temporal);
    if (r.unbiased) flag_checkbox("pairwise MIS", &r.pairwise);
    // Off: unshadowed targets in the reuse, one shadow ray when shading (the study's restir-unshadowed).
    flag_checkbox("visibility reuse", &r.visibility_reuse);
    // ris-bvh of the study: BVH candidates, no spatial pass, no temporal reuse.
    bool bvh = r.source == LightSelection::Bvh;
    if (ImGui::Checkbox("BVH candidates", &bvh)) r.source = bvh ? LightSelection::Bvh : LightSelection::Power;
    count_slider("candidates", &r.candidates, 1, 256, int(kMaxRestirCandidates), ImGuiSliderFlags_Logarithmic);
    count_slider("spatial passes", &r.spatial_passes, 0, 4, int(kMaxRestirPasses));
    ImGui::TextDisabled("%s", light_selection_label(in.light_selection, r).c_str());
  }
  ImGui::TextDisabled("%zu lights", scene_->lights.size());
  ImGui::SliderInt("spp / frame", &spp_per_frame_, 1, 256, "%d", ImGuiSliderFlags_Logarithmic);
  ImGui::SliderInt("max depth", &in.max_depth, 0, 32);
  ImGui::SliderFloat("exposure", &exposure_, -8.f, 8.f, "%+.1f stops");
  ImGui::SliderFloat("resolution", &scale_, 0.05f, 2.f, "x %.2f", ImGuiSliderFlags_Logarithmic);
  ImGui::Checkbox("denoise (N)", &denoise_);
  ImGui::SameLine();
  if (denoise_ && !denoiser_.empty())
    ImGui::TextDisabled("%s: %.1f ms a frame", denoiser_.c_str(), denoise_ms_);
  else
    ImGui::TextDisabled("Intel Open Image Denoise, albedo + normal guides");

  if (ImGui::CollapsingHeader("Split screen", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::Checkbox("split", &split_);
    ImGui::SameLine();
    ImGui::Checkbox("equal time", &equal_time_);
    if (split_) {
      strategy_combo("left", &left_);
      strategy_combo("right", &right_);
      ImGui::TextDisabled("keys 1-4: left side, shift+1-4: right side");
      ImGui::SliderFloat("divider", &divider_, 0.f, 1.f, "%.2f");
    }
  }
  if (ImGui::CollapsingHeader("Light", ImGuiTreeNodeFlags_DefaultOpen)) {
    if (!light_.sphere) {
      ImGui::TextDisabled("the first light is not a sphere");
    } else {
      ImGui::DragFloat("radius", &light_.radius, 0.002f * std::max(1.f, light_initial_.radius * 4), 1e-3f, 1e3f, "%.4g",
                       ImGuiSliderFlags_Logarithmic);
      light_.radius = std::max(light_.radius, 1e-4f);
      float c[3] = {light_.center.x, light_.center.y, light_.center.z};
      if (ImGui::DragFloat3("centre", c, 0.01f * std::max(1.f, camera_.distance() * 0.2f))) light_.center = {c[0], c[1], c[2]};
      float p[3] = {light_.power.x, light_.power.y, light_.power.z};
      if (ImGui::DragFloat3("power", p, 0.5f, 0.f, 1e9f)) light_.power = {std::max(p[0], 0.f), std::max(p[1], 0.f), std::max(p[2], 0.f)};
      if (ImGui::Button("reset light")) light_ = light_initial_;
    }
  }
  if (ImGui::CollapsingHeader("Camera")) {
    float fov = camera_.desc().fov;
    if (ImGui::SliderFloat("fov", &fov, 5.f, 120.f, "%.1f deg")) camera_.set_fov(fov);
    ImGui::Checkbox("fly (F)", &fly_);
    ImGui::SameLine();
    ImGui::SetNextItemWidth(120);
    ImGui::DragFloat("speed", &fly_speed_, fly_speed_ * 0.01f, 1e-4f, 1e6f, "%.3g/s", ImGuiSliderFlags_Logarithmic);
    if (ImGui::Button("reset (R)")) camera_.reset();
    ImGui::InputText("file", &camera_file_);
    if (ImGui::Button("save camera")) {
      try {
        save_camera_file(camera_file_);
      } catch (const std::exception& e) {
        status_ = e.what();
      }
    }
    ImGui::SameLine();
    if (ImGui::Button("load camera")) {
      try {
        load_camera_file(camera_file_);
      } catch (const std::exception& e) {
        status_ = e.what();
      }
    }
  }
  ImGui::Separator();
  if (ImGui::Button("screenshot (P)")) screenshot_requested_ = true;
  ImGui::SameLine();
  ImGui::TextDisabled("PNG + EXR");
  if (!status_.empty()) ImGui::TextWrapped("%s", status_.c_str());
  if (ImGui::CollapsingHeader("Controls")) {
    ImGui::TextWrapped(
        "left drag: orbit (fly: look)   middle or shift+left drag: pan   wheel: dolly (fly: speed)   "
        "F: fly mode, WASD/QE to move, shift: faster   R: reset camera   1-4: strategy (split: left; "
        "shift: right)   drag the divider   P: screenshot   Tab: panel");
  }
  ImGui::TextDisabled("%s", gl_info_.c_str());
  ImGui::End();
}

// The divider and the strategy of each side, drawn over the image (not part of screenshots of the image).
void Viewer::draw_overlay() {
  if (sides_.size() < 2) return;
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  const ImVec2 size = ImGui::GetIO().DisplaySize;
  const float x = float(divider_column()) / applied_.width * size.x;
  dl->AddLine(ImVec2(x, 0), ImVec2(x, size.y), IM_COL32(255, 255, 255, 200), 1.5f);
  for (const Side& s : sides_) {
    char label[64];
    std::snprintf(label, sizeof label, "%s  %llu spp", strategy_name(s.strategy), (unsigned long long)s.image->samples());
    ImVec2 ts = ImGui::CalcTextSize(label);
    float lx = &s == &sides_[0] ? x - ts.x - 8 : x + 8;
    float ly = size.y - ts.y - 6;
    dl->AddRectFilled(ImVec2(lx - 3, ly - 2), ImVec2(lx + ts.x + 3, ly + ts.y + 2), IM_COL32(0, 0, 0, 150));
    dl->AddText(ImVec2(lx, ly), IM_COL32(255, 255, 255, 255), label);
  }
}

}  // namespace pn::viewer
