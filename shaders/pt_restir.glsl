/* pt_restir.glsl: ReSTIR DI in the Vulkan front-end, the mirror of frontend_embree/femb_restir.c
 * (whose comment describes the algorithm; shaders/restir.h its constants): the surfaces, the
 * candidates and the temporal merge (the shading pass's mode 4), the spatial merge (mode 5), and
 * the light of a reservoir at the shading (restir_shade). The same random numbers as the Embree
 * front-end (TND_DIM_RESTIR_*), the same decisions; the arithmetic is the estimator's (lobes,
 * eval_brdf), so the two agree in expectation, not bit for bit. Included by pt_shade.glsl. */

/* A light sample resolved against the light list (femb_restir.c's rs_point). */
struct rs_point {
    vec3 x, n, axis, L;
    float cos_in, cos_out, area, env_pdf;
    uint kind;
    bool two_sided, far_, ok;
};

struct rs_res {
    uint light;
    float u, v, W, M;
};

const uint RS_MAX = 2u + TND_RESTIR_NEIGHBOURS;

uint rs_pixels()
{
    return fr.frame.y * fr.frame.z;
}

/* this frame's slot of the final reservoirs and surfaces; the previous frame's is the other */
uint rs_cur()
{
    return fr.restir.y & 1u;
}

rs_res rs_none(float M)
{
    return rs_res(TND_LT_NONE, 0.0, 0.0, 0.0, M);
}

rs_res rs_load(uint i)
{
    tnd_gpu_reservoir r = reservoirs[i];
    return rs_res(r.a.x, uintBitsToFloat(r.a.y), uintBitsToFloat(r.a.z), uintBitsToFloat(r.a.w),
                  r.b.x);
}

void rs_store(uint i, rs_res r)
{
    reservoirs[i].a = uvec4(r.light, floatBitsToUint(r.u), floatBitsToUint(r.v), floatBitsToUint(r.W));
    reservoirs[i].b = vec4(r.M, 0.0, 0.0, 0.0);
}

surface rs_surface(uint i, out float depth)
{
    tnd_gpu_rsurf r = rsurfs[i];
    surface s;
    s.p = r.p.xyz, s.ns = r.ns.xyz, s.ng = r.ng.xyz, s.wo = r.wo.xyz, s.base = r.base.rgb;
    s.roughness = r.ns.w, s.metallic = r.ng.w, s.specular = r.wo.w;
    s.emission = vec3(0.0), s.obj = vec3(0.0), s.sigma = vec3(0.0);
    s.inst = 0u, s.prim = 0u, s.kind = TND_KIND_OPAQUE, s.ior = 1.0, s.front = true;
    depth = r.p.w;
    return s;
}

rs_point rs_resolve(uint light, float u, float v)
{
    rs_point y;
    y.x = vec3(0.0), y.n = vec3(0.0), y.axis = vec3(0.0), y.L = vec3(0.0);
    y.cos_in = 0.0, y.cos_out = 0.0, y.area = 0.0, y.env_pdf = 0.0;
    y.kind = 0u, y.two_sided = false, y.far_ = false, y.ok = false;
    if (light >= fr.frame.w)
        return y;
    tnd_light_gpu l = lights[light];
    y.kind = uint(l.p0.w);
    y.L = l.radiance.rgb;
    y.ok = true;
    if (USES(TND_USES_AREA) && y.kind == TND_LIGHT_KIND_TRIANGLE) {
        float su = sqrt(u);
        y.x = l.p0.xyz * (1.0 - su) + l.p1.xyz * (su * (1.0 - v)) + l.p2.xyz * (su * v);
        y.n = safe_normalize(cross(l.p1.xyz - l.p0.xyz, l.p2.xyz - l.p0.xyz));
        y.two_sided = l.p1.w != 0.0;
        y.area = l.cdf.w;
        y.ok = y.area > 0.0;
    } else if (USES(TND_USES_POINT | TND_USES_SPOT) &&
               (y.kind == TND_LIGHT_KIND_POINT || y.kind == TND_LIGHT_KIND_SPOT)) {
        y.x = l.p0.xyz, y.axis = l.p1.xyz, y.cos_in = l.p2.x, y.cos_out = l.p2.y;
    } else if (USES(TND_USES_DIRECTIONAL) && y.kind == TND_LIGHT_KIND_DIRECTIONAL) {
        y.x = -l.p1.xyz, y.far_ = true;
    } else if (USES(TND_USES_ENV) && y.kind == TND_LIGHT_KIND_ENV) {
        vec3 d, rgb;
        y.env_pdf = env_sample(u, v, d, rgb);
        y.x = d, y.L = rgb, y.far_ = true;
        y.ok = y.env_pdf > 0.0;
    } else {
        y.ok = false;
    }
    return y;
}

/* The unshadowed contribution of y at s measured on the emitter: diffuse (demodulated) and
 * specular; the direction and distance to it. */
bool rs_contribution(rs_point y, surface s, out vec3 diff, out vec3 spec, out vec3 wi,
                     out float dist)
{
    diff = vec3(0.0), spec = vec3(0.0), wi = vec3(0.0, 1.0, 0.0), dist = 1e30;
    float J = 1.0;
    if (y.far_) {
        wi = y.x;
    } else {
        vec3 d = y.x - s.p;
        float d2 = dot(d, d);
        if (!(d2 > 0.0))
            return false;
        dist = sqrt(d2);
        wi = d * (1.0 / dist);
        J = 1.0 / d2;
        if (y.kind == TND_LIGHT_KIND_TRIANGLE) {
            float cfront = -dot(y.n, wi);
            float cosl = y.two_sided ? abs(cfront) : cfront;
            if (!(cosl > 0.0))
                return false;
            J *= cosl;
        } else if (y.kind == TND_LIGHT_KIND_SPOT) {
            float t = (-dot(wi, y.axis) - y.cos_out) / max(y.cos_in - y.cos_out, 1e-6);
            t = clamp(t, 0.0, 1.0);
            J *= t * t;
        }
    }
    if (!(J > 0.0))
        return false;
    float pdf_brdf;
    if (!eval_brdf(s, lobes(s), wi, diff, spec, pdf_brdf))
        return false;
    diff *= y.L * J;
    spec *= y.L * J;
    return true;
}

float rs_target(rs_point y, surface s)
{
    vec3 d, sp, wi;
    float dist;
    if (!y.ok || !rs_contribution(y, s, d, sp, wi, dist))
        return 0.0;
    vec3 c = d * s.base * (1.0 - s.metallic) + sp;
    float t = tnd_luminance(c.r, c.g, c.b);
    return t > 0.0 && t <= 3.0e38 ? t : 0.0;
}

float rs_source_pdf(rs_point y, float pick)
{
    if (y.kind == TND_LIGHT_KIND_TRIANGLE)
        return pick / y.area;
    if (y.kind >= TND_LIGHT_KIND_POINT && y.kind <= TND_LIGHT_KIND_DIRECTIONAL)
        return pick;
    return pick * y.env_pdf;
}

float rs_rnd(uvec2 key, uint dim)
{
    return tnd_rand(key.x, key.y, TND_SAMPLE_REALTIME, dim);
}

bool rs_alike(surface a, float a_depth, surface b, float b_depth)
{
    return dot(a.ns, b.ns) >= TND_RESTIR_NORMAL_DOT &&
           abs(b_depth - a_depth) <= TND_RESTIR_DEPTH_REL * a_depth;
}

/* n reservoirs r[i] from the domains of surfaces s[i] merged into one for s[0] by the generalized
 * balance heuristic (femb_restir.c merge) */
rs_res rs_merge(uint n, rs_res r[RS_MAX], surface s[RS_MAX], float u, float cap)
{
    float w[RS_MAX], pc[RS_MAX];
    float sum = 0.0, M = 0.0;
    for (uint i = 0u; i < n; i++) {
        M += r[i].M;
        w[i] = 0.0, pc[i] = 0.0;
        if (!(r[i].W > 0.0))
            continue;
        rs_point y = rs_resolve(r[i].light, r[i].u, r[i].v);
        if (!y.ok)
            continue;
        pc[i] = rs_target(y, s[0]);
        if (pc[i] == 0.0)
            continue;
        float own = 0.0, all = 0.0;
        for (uint j = 0u; j < n; j++) {
            float pj = j == 0u ? pc[i] : rs_target(y, s[j]);
            all += r[j].M * pj;
            own = j == i ? r[j].M * pj : own;
        }
        w[i] = all > 0.0 ? own / all * pc[i] * r[i].W : 0.0;
        sum += w[i];
    }
    rs_res o = rs_none(min(M, cap));
    if (!(sum > 0.0) || !(sum <= 3.0e38))
        return o;
    float pick = u * sum, acc = 0.0;
    for (uint i = 0u; i < n; i++) {
        if (w[i] == 0.0)
            continue;
        acc += w[i];
        if (pick < acc || o.light == TND_LT_NONE) {
            o.light = r[i].light, o.u = r[i].u, o.v = r[i].v;
            o.W = sum / pc[i];
            if (pick < acc)
                break;
        }
    }
    return o;
}

/* The surface of pixel ip from this frame's G-buffer as the shading reads it; false where the
 * pixel takes no reservoir (no surface, seen in a mirror or through glass, too smooth). */
bool rs_gather(ivec2 ip, out surface s, out float depth)
{
    s = gbuffer_surface(ip);
    s.emission = vec3(0.0), s.obj = vec3(0.0), s.sigma = vec3(0.0);
    s.kind = TND_KIND_OPAQUE, s.ior = 1.0, s.front = true, s.prim = 0u;
    uvec2 vis = imageLoad(img_vis_id, ip).xy;
    s.inst = vis.x;
    vec3 d = fr.cam_pos.xyz - s.p;
    depth = sqrt(dot(d, d));
    s.wo = depth > 0.0 ? d * (1.0 / depth) : s.ns;
    s.specular = 0.0;
    if (vis.x == TND_VIS_NONE)
        return false;
    s.specular = materials[meshes[instances[vis.x].info.x].info.x].params.y;
    if (imageLoad(img_path, ip).x != 0u)
        return false;
    return s.roughness >= TND_RESTIR_MIN_ROUGHNESS && depth > 0.0;
}

/* Mode 4: pixel ip's surface kept, its candidates, the merge with the previous frame's reservoir
 * where the motion vector points (femb_restir.c candidates_tile). */
void restir_candidates(ivec2 ip)
{
    uint W = fr.frame.y, H = fr.frame.z, N = rs_pixels();
    uint q = uint(ip.y) * W + uint(ip.x), cur = rs_cur();
    float cap = float(TND_RESTIR_HISTORY * TND_RESTIR_CANDIDATES);
    surface s;
    float depth;
    bool ok = rs_gather(ip, s, depth);
    rsurfs[cur * N + q] = tnd_gpu_rsurf(vec4(s.p, depth), vec4(s.ns, s.roughness),
                                        vec4(s.ng, s.metallic), vec4(s.wo, s.specular),
                                        vec4(s.base, 0.0));
    if (!ok) {
        rs_store(2u * N + q, rs_none(0.0));
        return;
    }
    uvec2 kr = imageLoad(img_rng, ip).xy;
    uvec2 key = uvec2(kr.y, kr.x); /* (pixel, frame) */
    rs_res r = rs_none(float(TND_RESTIR_CANDIDATES));
    float sum = 0.0, p_kept = 0.0;
    for (uint k = 0u; k < TND_RESTIR_CANDIDATES; k++) {
        uint dim = TND_DIM_RESTIR_CANDIDATE + 4u * k;
        float up = rs_rnd(key, dim), u = rs_rnd(key, dim + 1u), v = rs_rnd(key, dim + 2u);
        uint light;
        float pick;
        if (USES(TND_USES_LIGHT_TREE) && fr.indirect.y != 0u) {
            light = tnd_lt_sample(s.p.x, s.p.y, s.p.z, up, pick);
        } else {
            light = pick_light(up);
            pick = lights[light].radiance.w;
        }
        if (light == TND_LT_NONE || !(pick > 0.0))
            continue;
        rs_point y = rs_resolve(light, u, v);
        float src = y.ok ? rs_source_pdf(y, pick) : 0.0;
        float t = src > 0.0 ? rs_target(y, s) : 0.0;
        float w = t > 0.0 ? t / src : 0.0;
        if (!(w > 0.0) || !(w <= 3.0e38))
            continue;
        sum += w;
        if (rs_rnd(key, dim + 3u) * sum < w)
            r.light = light, r.u = u, r.v = v, p_kept = t;
    }
    r.W = p_kept > 0.0 ? sum / (float(TND_RESTIR_CANDIDATES) * p_kept) : 0.0;
    rs_res o = r;
    vec3 mo = imageLoad(img_motion, ip).xyz;
    float px = float(ip.x) + 0.5 + mo.x, py = float(ip.y) + 0.5 + mo.y;
    if ((fr.restir.y & 2u) != 0u && px >= 0.0 && py >= 0.0 && px < float(W) && py < float(H)) {
        uint pq = uint(py) * W + uint(px), prev = 1u - cur;
        rs_res pr = rs_load(prev * N + pq);
        float pdepth;
        surface ps = rs_surface(prev * N + pq, pdepth);
        if (pr.M > 0.0 && rs_alike(s, depth, ps, pdepth - mo.z)) {
            pr.M = min(pr.M, cap);
            rs_res in_r[RS_MAX];
            surface in_s[RS_MAX];
            in_r[0] = r, in_s[0] = s, in_r[1] = pr, in_s[1] = ps;
            o = rs_merge(2u, in_r, in_s, rs_rnd(key, TND_DIM_RESTIR_TEMPORAL), cap + r.M);
        }
    }
    rs_store(2u * N + q, o);
}

/* Mode 5: the merge with neighbours in a disc (femb_restir.c spatial_tile). */
void restir_spatial(ivec2 ip)
{
    uint W = fr.frame.y, H = fr.frame.z, N = rs_pixels();
    uint q = uint(ip.y) * W + uint(ip.x), cur = rs_cur();
    rs_res c = rs_load(2u * N + q);
    if (!(c.M > 0.0)) {
        rs_store(cur * N + q, c);
        return;
    }
    rs_res in_r[RS_MAX];
    surface in_s[RS_MAX];
    float depth, nd;
    in_r[0] = c;
    in_s[0] = rs_surface(cur * N + q, depth);
    uvec2 kr = imageLoad(img_rng, ip).xy;
    uvec2 key = uvec2(kr.y, kr.x);
    float radius = uintBitsToFloat(fr.restir.w);
    uint n = 1u;
    for (uint k = 0u; k < TND_RESTIR_NEIGHBOURS; k++) {
        uint dim = TND_DIM_RESTIR_SPATIAL + 2u * k;
        float a = 2.0 * PI * rs_rnd(key, dim);
        float rad = radius * sqrt(rs_rnd(key, dim + 1u));
        float nx = float(ip.x) + 0.5 + rad * cos(a), ny = float(ip.y) + 0.5 + rad * sin(a);
        if (!(nx >= 0.0 && ny >= 0.0 && nx < float(W) && ny < float(H)))
            continue;
        uint nq = uint(ny) * W + uint(nx);
        if (nq == q)
            continue;
        rs_res nr = rs_load(2u * N + nq);
        surface ns = rs_surface(cur * N + nq, nd);
        if (!(nr.M > 0.0) || !rs_alike(in_s[0], depth, ns, nd))
            continue;
        in_r[n] = nr, in_s[n] = ns, n++;
    }
    float cap = float(TND_RESTIR_HISTORY * TND_RESTIR_CANDIDATES);
    rs_store(cur * N + q, rs_merge(n, in_r, in_s, rs_rnd(key, TND_DIM_RESTIR_SPATIAL_KEEP), cap));
}

/* The reservoir the pixel with key (pixel, frame) shades with: this frame's, or the previous
 * frame's for a gradient sample; -1 where it has none. */
int rs_lookup(uint pixel, uint frame)
{
    uint N = rs_pixels(), cur = rs_cur();
    if (fr.restir.x == 0u || pixel >= N)
        return -1;
    uint i;
    if (frame == fr.frame.x)
        i = cur * N + pixel;
    else if ((fr.restir.y & 2u) != 0u && frame == fr.restir.z)
        i = (1u - cur) * N + pixel;
    else
        return -1;
    return reservoirs[i].b.x > 0.0 ? int(i) : -1;
}

/* The light of reservoir r at surface s: one shadow ray as next-event estimation casts it
 * (direct_light), f(y) V(y) W. */
void restir_shade(rs_res r, surface s, out vec3 diff, out vec3 spec)
{
    diff = vec3(0.0), spec = vec3(0.0);
    if (!(r.W > 0.0))
        return;
    rs_point y = rs_resolve(r.light, r.u, r.v);
    vec3 d, sp, wi;
    float dist;
    if (!y.ok || !rs_contribution(y, s, d, sp, wi, dist))
        return;
    vec3 org = offset_ray(s.p, s.ng);
    if (y.far_) {
        if (trace_occluded(org, wi, 1e30))
            return;
    } else {
        vec3 end = y.x;
        if (y.kind == TND_LIGHT_KIND_TRIANGLE)
            end = y.x + (-dot(y.n, wi) >= 0.0 ? y.n : -y.n) *
                            tnd_offset_eps(max(tnd_max_abs(y.x), tnd_max_abs(s.p)));
        vec3 sd = end - org;
        float sl = sqrt(dot(sd, sd));
        if (dot(sd, y.x - s.p) > 0.0 && trace_occluded(org, sd * (1.0 / sl), sl))
            return;
    }
    diff = d * r.W;
    spec = sp * r.W;
}
