#include "socketsmith/report/limb_views.h"

#include <algorithm>

namespace socketsmith::report {

Image render_limb_views(const geometry::TriMesh& skin, const std::vector<volume::NamedMesh>& bones,
                        const std::vector<volume::Landmark>& landmarks, const geometry::LimbFrame& frame,
                        const std::string& title, bool bones_estimated, int view_px) {
  std::vector<MeshLayer> layers;
  for (const auto& b : bones) {
    MeshLayer l;
    l.mesh = &b.mesh;
    l.colour = bones_estimated ? Rgb{205, 190, 150} : Rgb{235, 225, 200};
    layers.push_back(l);
  }
  MeshLayer s;
  s.mesh = &skin;
  s.colour = {214, 170, 150};
  s.opacity = bones.empty() ? 1.0 : 0.45;
  layers.push_back(s);
  std::vector<Marker> markers;
  for (const auto& l : landmarks) {
    Marker m;
    m.position = l.position;
    m.label = l.code;
    m.colour = l.estimated ? Rgb{200, 40, 40} : Rgb{30, 90, 200};
    markers.push_back(m);
  }
  // A camera looks along view_dir: to see the front, look along -anterior.
  const std::vector<std::pair<Camera, std::string>> views{
      {{-frame.anterior, frame.axis}, "anterior"},
      {{-frame.lateral(), frame.axis}, "lateral"},
      {{frame.anterior, frame.axis}, "posterior"},
      {{frame.lateral(), frame.axis}, "medial"}};
  // Top row: translucent skin over the bones. Bottom row: opaque skin with the landmarks that
  // face the camera (a translucent skin cannot hide the ones behind it).
  const Image top = render_views(layers, {}, views, view_px,
                                 title + (bones_estimated ? "  (bones estimated)" : ""));
  MeshLayer opaque = s;
  opaque.opacity = 1.0;
  const Image bottom = render_views({opaque}, markers, views, view_px, "landmarks (red: placed automatically)");
  Image out(std::max(top.width, bottom.width), top.height + bottom.height, Rgb{255, 255, 255});
  for (int y = 0; y < top.height; ++y)
    for (int x = 0; x < top.width; ++x) out.at(x, y) = top.pixels[static_cast<size_t>(y) * top.width + x];
  for (int y = 0; y < bottom.height; ++y)
    for (int x = 0; x < bottom.width; ++x)
      out.at(x, top.height + y) = bottom.pixels[static_cast<size_t>(y) * bottom.width + x];
  return out;
}

}  // namespace socketsmith::report
