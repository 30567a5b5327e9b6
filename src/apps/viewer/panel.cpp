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

// The panel's controls set the viewer through its actions (actions_table.h),
// as keys and camera paths do; `where` for the actions' messages.
const std::string kPanel = "the panel";

// A combo box over one of the registries' enums, listed by their names; true
// when the user chose another (then *value).
template <class E>
bool enum_combo(const char* label, E* value, int count, const char* (*name)(E)) {
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
          &names, count)) {
    *value = E(i);
    return true;
  }
  return false;
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
  ImGui::Text("image %dx%d, display: %s", scheduler_.applied().width, scheduler_.applied().height,
              display_path_name(display_path_.path));
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
              scheduler_.seconds_since_restart());
  const std::vector<Side>& sides = scheduler_.sides();
  for (const Side& s : sides)
    ImGui::Text("%s%-11s %5llu spp %6.3g us/px", sides.size() > 1 ? (&s == &sides[0] ? "left  " : "right ") : "",
                strategy_name(s.strategy), (unsigned long long)s.image->samples(), s.seconds_per_pixel() * 1e6);

  // ImGui's widgets write the value they show: each gets a copy of the viewer's, and a change becomes its action.
  auto strategy_combo = [this](const char* label, const char* action, Strategy s) {
    int i = int(s);
    bool changed = ImGui::Combo(
        label, &i,
        [](void*, int k, const char** out) {
          static char names[kNumStrategies][32];
          std::snprintf(names[k], sizeof names[k], "%d: %s", k + 1, strategy_name(Strategy(k)));
          *out = names[k];
          return true;
        },
        nullptr, kNumStrategies);
    if (changed) act(action, strategy_name(Strategy(i)), kPanel);
  };
  auto checkbox = [this](const char* label, const char* action, bool b) {
    if (ImGui::Checkbox(label, &b)) act(action, b, kPanel);
  };
  auto slider_int = [this](const char* label, const char* action, int v, int lo, int hi, ImGuiSliderFlags flags = 0) {
    if (ImGui::SliderInt(label, &v, lo, hi, "%d", flags)) act(action, v, kPanel);
  };
  auto slider_float = [this](const char* label, const char* action, float v, float lo, float hi, const char* format,
                             ImGuiSliderFlags flags = 0) {
    if (ImGui::SliderFloat(label, &v, lo, hi, format, flags)) act(action, v, kPanel);
  };
  // restir's counts: a typed value may leave the slider's range; it is clamped to [lo, most].
  auto count_slider = [this](const char* label, const char* action, uint32_t count, int lo, int hi, int most,
                             ImGuiSliderFlags flags = 0) {
    int v = int(count);
    ImGui::SliderInt(label, &v, lo, hi, "%d", flags);
    const uint32_t clamped = uint32_t(std::clamp(v, lo, most));
    if (clamped != count) act(action, clamped, kPanel);
  };
  ImGui::Separator();
  const IntegratorSettings& in = integrator_;
  if (!split_) strategy_combo("strategy", "strategy", in.strategy);
  Mis mis = in.mis;
  if (enum_combo("MIS", &mis, kNumMisModes, mis_name)) act("mis", mis_name(mis), kPanel);
  // How the light of each sample is chosen (restir with the scene's
  // render.restir settings; temporal reuse between frames as the panel says).
  LightSelection selection = in.light_selection;
  if (enum_combo("light selection", &selection, kNumLightSelections, light_selection_name))
    act("light_selection", light_selection_name(selection), kPanel);
  if (in.light_selection == LightSelection::Restir) {
    const RestirSettings& r = in.restir;
    checkbox("temporal reuse", "restir_temporal", r.temporal != 0);
    if (r.unbiased) checkbox("pairwise MIS", "restir_pairwise", r.pairwise != 0);
    // Off: unshadowed targets in the reuse, one shadow ray when shading (the study's restir-unshadowed).
    checkbox("visibility reuse", "restir_visibility_reuse", r.visibility_reuse != 0);
    // ris-bvh of the study: BVH candidates, no spatial pass, no temporal reuse.
    checkbox("BVH candidates", "restir_bvh_candidates", r.source == LightSelection::Bvh);
    count_slider("candidates", "restir_candidates", r.candidates, 1, 256, int(kMaxRestirCandidates),
                 ImGuiSliderFlags_Logarithmic);
    count_slider("spatial passes", "restir_spatial", r.spatial_passes, 0, 4, int(kMaxRestirPasses));
    ImGui::TextDisabled("%s", light_selection_label(in.light_selection, r).c_str());
  }
  ImGui::TextDisabled("%zu lights", scene_->lights.size());
  slider_int("spp / frame", "spp_per_frame", spp_per_frame_, 1, 256, ImGuiSliderFlags_Logarithmic);
  slider_int("max depth", "max_depth", in.max_depth, 0, 32);
  slider_float("exposure", "exposure", exposure_, -8.f, 8.f, "%+.1f stops");
  slider_float("resolution", "scale", scale_, 0.05f, 2.f, "x %.2f", ImGuiSliderFlags_Logarithmic);
  checkbox("denoise (N)", "denoise", denoise_);
  ImGui::SameLine();
  if (denoise_ && !denoiser_.empty())
    ImGui::TextDisabled("%s: %.1f ms a frame", denoiser_.c_str(), denoise_ms_);
  else
    ImGui::TextDisabled("Intel Open Image Denoise, albedo + normal guides");

  if (ImGui::CollapsingHeader("Split screen", ImGuiTreeNodeFlags_DefaultOpen)) {
    checkbox("split", "split", split_);
    ImGui::SameLine();
    checkbox("equal time", "equal_time", equal_time_);
    if (split_) {
      strategy_combo("left", "split_left", left_);
      strategy_combo("right", "split_right", right_);
      ImGui::TextDisabled("keys 1-4: left side, shift+1-4: right side");
      slider_float("divider", "divider", divider_, 0.f, 1.f, "%.2f");
    }
  }
  // The light's controls edit light_ in place, not through the light actions: the radius is held above 1e-4 every
  // frame and "reset light" restores the whole edit, neither of which is one action's value.
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
    if (ImGui::SliderFloat("fov", &fov, 5.f, 120.f, "%.1f deg")) act("fov", fov, kPanel);
    checkbox("fly (F)", "fly", fly_);
    ImGui::SameLine();
    ImGui::SetNextItemWidth(120);
    float speed = fly_speed_;
    if (ImGui::DragFloat("speed", &speed, fly_speed_ * 0.01f, 1e-4f, 1e6f, "%.3g/s", ImGuiSliderFlags_Logarithmic))
      act("fly_speed", speed, kPanel);
    if (ImGui::Button("reset (R)")) act("reset", true, kPanel);
    ImGui::InputText("file", &camera_file_);
    // A file that cannot be written or read: its message in the panel.
    auto file_button = [this](const char* label, const char* action) {
      if (!ImGui::Button(label)) return;
      try {
        act(action, camera_file_, kPanel);
      } catch (const std::exception& e) {
        status_ = e.what();
      }
    };
    file_button("save camera", "save_camera");
    ImGui::SameLine();
    file_button("load camera", "load_camera");
  }
  ImGui::Separator();
  if (ImGui::Button("screenshot (P)")) act("screenshot_button", true, kPanel);
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
  const std::vector<Side>& sides = scheduler_.sides();
  if (sides.size() < 2) return;
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  const ImVec2 size = ImGui::GetIO().DisplaySize;
  const float x = float(scheduler_.divider_column(divider_)) / scheduler_.applied().width * size.x;
  dl->AddLine(ImVec2(x, 0), ImVec2(x, size.y), IM_COL32(255, 255, 255, 200), 1.5f);
  for (const Side& s : sides) {
    char label[64];
    std::snprintf(label, sizeof label, "%s  %llu spp", strategy_name(s.strategy), (unsigned long long)s.image->samples());
    ImVec2 ts = ImGui::CalcTextSize(label);
    float lx = &s == &sides[0] ? x - ts.x - 8 : x + 8;
    float ly = size.y - ts.y - 6;
    dl->AddRectFilled(ImVec2(lx - 3, ly - 2), ImVec2(lx + ts.x + 3, ly + ts.y + 2), IM_COL32(0, 0, 0, 150));
    dl->AddText(ImVec2(lx, ly), IM_COL32(255, 255, 255, 255), label);
  }
}

}  // namespace pn::viewer
