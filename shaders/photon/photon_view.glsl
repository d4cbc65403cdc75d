// The photon-map view: every photon hit at a non-delta surface seen by the camera adds
// the photon's power to the pixel it projects to (the splat image, storage block 7), so
// the picture shows where the photons are, coloured by power. SPPM's photon pass and
// the photon integrator's tracing kernel splat with it when asked.
#include "photon/photon_tracer.glsl"
#include "integrators/splat.glsl"

void splat_photon_view(SurfaceHit hit, Photon ph, vec2 u_lens) {
    CameraConnection c = camera_connect(hit.p, u_lens, ph.time);
    if (c.valid && camera_visible(hit.p, hit.ng, c, ph.time, kNoPrimitive)) splat_film(c.film, ph.beta);
}

