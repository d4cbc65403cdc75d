// SPPM's photon step: a photon at a surface adds its contribution to every visible
// point whose search disk holds it (Hachisuka & Jensen 2009; pbrt-v3 SPPMIntegrator).
//
// For visible point i with throughput beta_i, radius r_i, outgoing direction wo_i:
//     Phi_i += K(d / r_i) beta_i f_i(wo_i, wi) beta_photon,   M_i += 1,
// with K the density kernel (mean 1 over the disk; uniform in pbrt's SPPM),
// where wi points back along the photon. The host turns Phi and M into the
// progressive radiance estimate (glrender/photon/sppm.py). Only visible points whose
// geometric normal agrees with the photon's surface count (kNormalAgreement): a
// photon on the far side of a thin wall, or on the other wall of a corner, is
// another surface. Every photon visits at most kMaxCellCandidates entries of its
// cell and kCandidateBudget over its whole path, far below llvmpipe's silent
// ~65,535-iteration cap; skipped entries are counted (photon_records[0]).
// (the kernel enables GL_NV_shader_atomic_float: #extension must precede all code)
#include "photon/layout.glsl"
#include "photon/hash_grid.glsl"
#include "integrators/integrator_common.glsl"
#include "bsdf/bsdf.glsl"
#include "bsdf/material.glsl"
#include "photon/density.glsl"
#include "media/medium.glsl"

const uint kMaxCellCandidates = 4096u;

const uint kCandidateBudget = 16384u;

// Volume photons (kMedia): a photon that scatters at p in medium m deposits into the
// visible points in the same medium (vp_position w < 0, photon/layout.glsl) whose search
// sphere holds it: Phi_i += K3(d / r_i) beta_i p(wo_i, wi) beta_photon, with beta_photon
// its power over sigma_s (media/medium.glsl medium_over_sigma_s: the density of those
// powers is the incident radiance) and K3 a kernel of mean 1 over the ball; the host divides by
// (4/3) pi r^3. A camera path's beta_i at its scattering event carries sigma_s T over
// the free flight's density, so beta_i times the in-scattered radiance int p L_i is
// that event's share of the pixel: unbiased in the limit r -> 0.

// Deposits a photon of power beta that reached surface point p (geometric normal ng)
// from the unit direction wi (pointing back toward where it came from), after
// `segments` path segments from its light; a volume photon (kMedia) at a scattering
// event in medium `medium` (ng 0; kNoMedium: a surface photon). `budget`: candidates
// this photon may still visit.
void sppm_deposit(vec3 p, vec3 ng, int medium, vec3 wi, vec3 beta, int segments, inout uint budget,
                  inout uint visited) {
    uvec3 cell;
    if (!grid_cell_of(p, cell)) return;
    uvec2 range = grid_cell_range(cell);
    uint n = range.y - range.x;
    uint visit = min(n, min(kMaxCellCandidates, budget));
    if (visit < n) atomicAdd(photon_records[0], n - visit);
    budget -= visit;
    visited += visit;
    float max_segments = float(u_photon.options.y);
    for (uint k = 0u; k < visit; ++k) {
        LOOP_TICK();
        uint i = grid_cells[range.x + k];
        vec4 vp = vp_position[i];
        vec3 dp = p - vp.xyz;
        if (kMedia && medium != kNoMedium) {
            if (vp.w >= 0.0 || dot(dp, dp) > vp_radius2[i] || float(segments) - vp.w > max_segments)
                continue;
            vec4 wo = vp_shading[2u * i];
            if (floatBitsToInt(wo.w) != medium) continue;
            float w = density_kernel_3d(u_photon.estimate.x, dot(dp, dp) / vp_radius2[i]);
            vec3 phi = vp_extra[2u * i + 1u].rgb * (w * medium_phase(medium, -wo.xyz, wi)) * beta;
            if (!is_finite(phi)) continue;
            atomicAdd(deposit_flux[4u * i], phi.r);
            atomicAdd(deposit_flux[4u * i + 1u], phi.g);
            atomicAdd(deposit_flux[4u * i + 2u], phi.b);
            atomicAdd(deposit_flux[4u * i + 3u], 1.0);
            continue;
        }
        if (dot(dp, dp) > vp_radius2[i] || vp.w + float(segments) > max_segments) continue;
        vec4 extra = vp_extra[2u * i];
        if (dot(extra.xyz, ng) < kNormalAgreement) continue;
        vec4 s0 = vp_shading[2u * i], s1 = vp_shading[2u * i + 1u];
        Bsdf b = bsdf_from_material(floatBitsToUint(s0.w), vec2(s1.w, extra.w));
        Frame frame = frame_from_z(s1.xyz);
        if (kNormalShadowing)
            b.n0 = vp_unpack_unit(vp_extra[2u * i + 1u].w);   // bsdf_normal_frame's, in this frame
        vec3 f;
        if (!photon_bsdf(b, frame, frame_to_local(frame, s0.xyz), extra.xyz, wi, f)) continue;
        float w = density_kernel(u_photon.estimate.x, dot(dp, dp) / vp_radius2[i]);
        vec3 phi = vp_extra[2u * i + 1u].rgb * w * f * beta;
        if (!is_finite(phi)) continue;
        atomicAdd(deposit_flux[4u * i], phi.r);
        atomicAdd(deposit_flux[4u * i + 1u], phi.g);
        atomicAdd(deposit_flux[4u * i + 2u], phi.b);
        atomicAdd(deposit_flux[4u * i + 3u], 1.0);
    }
}
