// UsdSkel deformation, the one body of both forms of the skinning pass: transform
// feedback (skin.vert, GL 3.3) and compute (skin.comp, GL 4.3). Call
// skin_vertex(point, p, n, t) on a vertex's own position, normal and tangent, `point`
// the mesh point it is (per-point data); the results are in skeleton space (drawn with
// the skeleton's local-to-world). The including shader reads the vertices and writes
// the results, and provides what it alone can read:
//   vertex_influences(h, j, w)  the h-th group of 4 joint influences of this vertex
//                               (SKIN_JOINTS without SKIN_JOINTS_TEX)
//   deformed_position(v)        vertex v of the mesh as already deformed
//                               (SKIN_SURFACE_NORMALS)
// Variant defines, only for what a mesh uses:
//   SKIN_SHAPES   blend shapes, offsets texture indexed by (block * points + point)
//   SKIN_JOINTS   joint influences (4 per vertex; SKIN_JOINTS8: 8; SKIN_JOINTS_TEX:
//                 any number, read per point from the influence texture)
//   SKIN_DQS      dual-quaternion skinning instead of linear blend
//   SKIN_SURFACE_NORMALS  (on the already deformed vertices) normals are the
//                 surface's own, gathered per point from its triangles: surface_frame
// Joint texture: one row per joint, see engine/skin.py joint_texels.
const int FLAT_TEX_W = 4096;   // engine/skin.py FLAT_TEX_W
vec4 flat_texel(sampler2D tex, int i) { return texelFetch(tex, ivec2(i % FLAT_TEX_W, i / FLAT_TEX_W), 0); }

#ifdef SKIN_SHAPES
uniform sampler2D u_shape_offsets;
uniform sampler2D u_shape_active;   // x: offsets block, y: normal-offsets block, z: weight
uniform int u_shape_count;
uniform int u_shape_points;
vec3 shape_texel(int block, int point) {
    return flat_texel(u_shape_offsets, block * u_shape_points + point).xyz;
}
#endif

#ifdef SKIN_JOINTS
#ifdef SKIN_JOINTS_TEX
uniform sampler2D u_influences;
uniform int u_influence_groups;
void influence_group(int point, int h, out ivec4 j, out vec4 w) {
    int i = 2 * (point * u_influence_groups + h);
    j = ivec4(flat_texel(u_influences, i));
    w = flat_texel(u_influences, i + 1);
}
#else
void vertex_influences(int h, out ivec4 j, out vec4 w);
void influence_group(int point, int h, out ivec4 j, out vec4 w) { vertex_influences(h, j, w); }
#endif
uniform sampler2D u_joint_xforms;
uniform mat4 u_geom_bind;
uniform mat3 u_geom_bind_normal;

vec4 joint_texel(int j, int k) { return texelFetch(u_joint_xforms, ivec2(k, j), 0); }

vec3 qrot(vec4 q, vec3 v) { return v + 2.0 * cross(q.xyz, cross(q.xyz, v) + q.w * v); }
vec4 qmul(vec4 a, vec4 b) {
    return vec4(a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz), a.w * b.w - dot(a.xyz, b.xyz));
}
#endif

void skin_vertex(int point, inout vec3 p, inout vec3 n, inout vec3 t) {
#ifdef SKIN_SHAPES
    for (int s = 0; s < u_shape_count; ++s) {
        vec4 a = texelFetch(u_shape_active, ivec2(s, 0), 0);
        if (a.x >= 0.0) p += a.z * shape_texel(int(a.x), point);
        if (a.y >= 0.0) n += a.z * shape_texel(int(a.y), point);
    }
#endif
#ifdef SKIN_JOINTS
#if defined(SKIN_JOINTS_TEX)
    int H = u_influence_groups;
#elif defined(SKIN_JOINTS8)
    const int H = 2;
#else
    const int H = 1;
#endif
    vec4 P = u_geom_bind * vec4(p, 1.0);
    vec3 N = u_geom_bind_normal * n;
    vec3 T = mat3(u_geom_bind) * t;
    vec3 sp = vec3(0.0), sn = vec3(0.0), st = vec3(0.0);
#ifdef SKIN_DQS
    // UsdSkel's DQS: the scale parts blended linearly on the point, the rigid parts
    // as dual quaternions flipped into the first influence's hemisphere.
    vec4 qr = vec4(0.0), qd = vec4(0.0), pivot = vec4(0.0);
    bool has_pivot = false;
#endif
    for (int h = 0; h < H; ++h) {
        ivec4 Jh;
        vec4 Wh;
        influence_group(point, h, Jh, Wh);
        for (int k = 0; k < 4; ++k) {
            float w = Wh[k];
            if (w == 0.0) continue;
            int j = Jh[k];
#ifdef SKIN_DQS
            vec3 s0 = joint_texel(j, 8).xyz, s1 = joint_texel(j, 9).xyz, s2 = joint_texel(j, 10).xyz;
            sp += w * vec3(dot(s0, P.xyz), dot(s1, P.xyz), dot(s2, P.xyz));
            st += w * vec3(dot(s0, T), dot(s1, T), dot(s2, T));
            vec3 n0 = joint_texel(j, 11).xyz, n1 = joint_texel(j, 12).xyz, n2 = joint_texel(j, 13).xyz;
            sn += w * vec3(dot(n0, N), dot(n1, N), dot(n2, N));
            vec4 q = joint_texel(j, 6), d = joint_texel(j, 7);
            if (!has_pivot) { pivot = q; has_pivot = true; }
            float sw = dot(q, pivot) < 0.0 ? -w : w;
            qr += sw * q;
            qd += sw * d;
#else
            vec4 r0 = joint_texel(j, 0), r1 = joint_texel(j, 1), r2 = joint_texel(j, 2);
            sp += w * vec3(dot(r0, P), dot(r1, P), dot(r2, P));
            st += w * vec3(dot(r0.xyz, T), dot(r1.xyz, T), dot(r2.xyz, T));
            vec3 n0 = joint_texel(j, 3).xyz, n1 = joint_texel(j, 4).xyz, n2 = joint_texel(j, 5).xyz;
            sn += w * vec3(dot(n0, N), dot(n1, N), dot(n2, N));
#endif
        }
    }
#ifdef SKIN_DQS
    float len = length(qr);
    if (len > 0.0) {
        qr /= len;
        qd /= len;
        vec3 trans = 2.0 * qmul(qd, vec4(-qr.xyz, qr.w)).xyz;
        sp = qrot(qr, sp) + trans;
        sn = qrot(qr, sn);
        st = qrot(qr, st);
    }
#endif
    p = sp;
    n = sn;
    t = st;
#endif
    // UsdSkel normalises each skinned normal (its baked twin stores unit normals):
    // unnormalised ones, interpolated across a triangle, would tilt the shading.
    float n_len = length(n);
    if (n_len > 0.0) n /= n_len;
}

#ifdef SKIN_SURFACE_NORMALS
// The deformed surface's own normal at `point`, as engine/usd/mesh.py's smooth
// normals (area-weighted per point), and the tangent made orthogonal to it again.
uniform sampler2D u_incidence;   // engine/skin.py incidence_texels
uniform int u_points;
vec3 deformed_position(int v);
void surface_frame(int point, out vec3 n, inout vec3 t) {
    vec4 range = flat_texel(u_incidence, point);
    vec3 sum = vec3(0.0);
    for (int i = 0; i < int(range.y); ++i) {
        ivec3 tri = ivec3(flat_texel(u_incidence, u_points + int(range.x) + i).xyz);
        vec3 a = deformed_position(tri.x);
        sum += cross(deformed_position(tri.y) - a, deformed_position(tri.z) - a);
    }
    n = sum / max(length(sum), 1e-30);
    vec3 tt = t - n * dot(n, t);
    float t_len = length(tt);
    if (t_len > 0.0) t = tt / t_len;
}
#endif
