// The light tree (engine/light_tree.py builds it and documents the node): many point
// lights as groups, a group shaded as one light where it stands for its lights within
// the bound. Include after lights.glsl.
uniform sampler2D u_tree;           // NODES_PER_LINE nodes a line (engine/gpu/lights.py)
uniform int tree_leaves;            // 0: no tree
uniform bool tree_exact;            // error 0: every light on its own, within its volume
const int NODE_TEXELS = 8;
const int NODES_PER_LINE = 256;
const float ERROR_CONSTANT = 1.5;   // engine/light_tree.py
const float MIN_GROUP_RADII = 2.0;

vec4 node_texel(int i, int k) {
    return texelFetch(u_tree, ivec2(k + (i % NODES_PER_LINE) * NODE_TEXELS, i / NODES_PER_LINE), 0);
}
bool node_is_leaf(int i) { return i >= tree_leaves - 1; }
// Camera-relative centroid of node i.
vec3 node_centre(int i) { return rebase(node_texel(i, 0).xyz, node_texel(i, 1).xyz); }
float node_list_distance(int i) { return node_texel(i, 0).w; }
float node_radius(int i) { return node_texel(i, 1).w; }
float node_count(int i) { return node_texel(i, 2).w; }
float node_reach(int i) { return node_texel(i, 3).w; }
int node_light_row(int i) { return int(node_texel(i, 5).w); }
float node_spread(int i) { return node_texel(i, 6).w; }

// Whether group i stands for its lights at a surface facing n, u = centre - p, d = |u|,
// whose light from the tree is at least `total` (light_tree.py: its error bound within
// light_error of its own irradiance there, or, from MIN_GROUP_RADII radii, of `total`;
// its lights all above the horizon is the caller's test).
bool group_holds(int i, vec3 u, float d, vec3 n, vec3 total) {
    float r = node_radius(i);
    float bound = ERROR_CONSTANT * r * r * r / (d * d) + 3.0 * node_spread(i);
    return !tree_exact && (bound <= light_error * dot(n, u)
        || (d >= MIN_GROUP_RADII * r
            && all(lessThanEqual(node_texel(i, 2).rgb * bound, light_error * d * d * d * total))));
}

// The range of n.(x - p) over node i's box of lights, for a surface at p facing n
// (centre: its camera-relative centroid): all above the horizon when .x > 0, all below
// when .y <= 0.
vec2 node_horizon(int i, vec3 centre, vec3 p, vec3 n) {
    vec3 lo = node_texel(i, 6).xyz, hi = node_texel(i, 7).xyz;
    vec3 a = n * lo, b = n * hi;
    float base = dot(n, centre - p);
    return base + vec2(dot(min(a, b), vec3(1.0)), dot(max(a, b), vec3(1.0)));
}

// The irradiance per unit power that group i sends onto (p, n), u = centre - p: the
// light at its centroid plus the second-order term of its spread (light_tree.py
// group_irradiance, which the tests compare with this).
float group_irradiance(int i, vec3 u, vec3 n) {
    vec4 c0 = node_texel(i, 4), c1 = node_texel(i, 5);
    mat3 M = mat3(c0.x, c0.w, c1.x,
                  c0.w, c0.y, c1.y,
                  c1.x, c1.y, c0.z);
    float d2 = dot(u, u);
    float d = sqrt(d2);
    float nu = dot(n, u);
    float d5 = d2 * d2 * d;
    float corr = (-3.0 * dot(n, M * u) - 1.5 * nu * (c0.x + c0.y + c0.z)) / d5
               + 7.5 * nu * dot(u, M * u) / (d5 * d2);
    return nu / (d2 * d) + corr;
}

// Group i (all of its lights above s's horizon) seen from s, for point_reflected
// (lights.glsl): its diffuse power through group_irradiance, its specular power as a
// sphere light of the group's radius at the centroid (the lobe widened, as
// sphere_emitter widens it); false where it is below s's horizon.
bool group_emitter(Surface s, int i, vec3 centre, out vec3 l, out vec3 Ed, out vec3 Es,
                   out float widen) {
    vec3 u = centre - s.p;
    float d = length(u);
    l = u / d;
    float NoL = dot(s.n, l);
    Ed = Es = vec3(0.0);
    widen = node_radius(i) / max(2.0 * d, 1e-6);
    if (NoL <= 0.0) return false;
    Ed = node_texel(i, 2).rgb * max(group_irradiance(i, u, s.n), 0.0) * bump_visible(s, l);
    Es = node_texel(i, 3).rgb * (NoL / (d * d)) * bump_visible(s, l);
    return true;
}

// The node after i in a depth-first walk of root's subtree once i's own subtree is done:
// the right sibling of i or of its nearest ancestor below root that has one; -1 when
// the walk is over. The tree is complete and implicit (children 2i+1, 2i+2): numbered
// from 1 (k = i + 1), right children are odd, so the climb is a shift past k's trailing
// ones, and the walk needs neither a stack nor a loop of its own (llvmpipe ends a
// shader invocation's loops after 65,535 iterations in all: a walk costs one a node).
int tree_next(int i, int root) {
    int k = (i + 1) >> findLSB(~(i + 1));         // up to the nearest left child
    return findMSB(k) <= findMSB(root + 1) ? -1 : k;  // its right sibling, 0-based
}

// The greatest distance from p to node i's box of lights (centre: its camera-relative
// centroid); at most its distance plus its radius.
float node_farthest(int i, vec3 centre, vec3 p) {
    vec3 q = p - centre;
    return length(max(abs(node_texel(i, 6).xyz - q), abs(node_texel(i, 7).xyz - q)));
}

// A lower bound of the diffuse light (irradiance per channel) that root's subtree sends
// onto s: a coarse cut, each group at least MIN_GROUP_RADII radii away with all of its
// lights above the horizon counted as its power times its lights' least n.u over
// their box's greatest distance cubed (a leaf: its own light), below the horizon
// nothing. Adds the nodes visited to steps.
vec3 tree_lower_bound(Surface s, int root, inout uint steps) {
    vec3 total = vec3(0.0);
    int i = root;
    while (i >= 0) {
        ++steps;
        bool down = false;
        if (node_count(i) > 0.0) {
            vec3 centre = node_centre(i);
            float d = length(centre - s.p), r = node_radius(i);
            vec2 horizon = node_horizon(i, centre, s.p, s.n);
            if (horizon.y <= 0.0) {
                // every light below the horizon: nothing
            } else if (horizon.x > 0.0 && d >= MIN_GROUP_RADII * r) {
                float far = node_farthest(i, centre, s.p);
                total += node_texel(i, 2).rgb * horizon.x / (far * far * far);
            } else {
                down = !node_is_leaf(i);
            }
        }
        i = down ? 2 * i + 1 : tree_next(i, root);
    }
    return total;
}

// What node i's lights send from s, added to sum_d and sum_g; view_forward: the
// camera's axis (a headlight's direction); total: a lower bound of s's light from the
// tree (tree_lower_bound). Walking down its subtree: a group as one light where it
// holds (group_holds) and is above the horizon, else its parts the same way, and each
// leaf as its light. Every step shades at most one emitter, a leaf or a group, through
// one point_reflected: llvmpipe runs every branch of a shader, masked, so a step costs
// one BRDF however the tree is walked. Adds the nodes visited to steps.
void shade_node(Surface s, int root, vec3 view_forward, vec3 total, inout vec3 sum_d,
                inout vec3 sum_g, inout uint steps) {
    int i = root;
    while (i >= 0) {
        ++steps;
        bool down = false, emits = false;
        vec3 l, Ed, Es;
        float widen;
        if (node_is_leaf(i)) {
            if (node_count(i) > 0.0) {
                load_light(node_light_row(i), view_forward);
                if (!tree_exact) light_range = 3.0e38;       // a tree light has no volume
                emits = sphere_emitter(s, l, Ed, Es, widen);
            }
        } else if (node_count(i) > 0.0) {
            vec3 centre = node_centre(i);
            float d = length(centre - s.p);
            vec2 horizon = node_horizon(i, centre, s.p, s.n);
            if ((tree_exact && d > node_reach(i)) || horizon.y <= 0.0) {
                // out of reach, or every light below the horizon: nothing
            } else if (horizon.x > 0.0 && group_holds(i, centre - s.p, d, s.n, total)) {
                emits = group_emitter(s, i, centre, l, Ed, Es, widen);
            } else {
                down = true;
            }
        }
        if (emits) {
            vec3 diffuse, glossy;
            point_reflected(s, l, Ed, Es, widen, diffuse, glossy);
            sum_d += diffuse;
            sum_g += glossy;
        }
        i = down ? 2 * i + 1 : tree_next(i, root);
    }
}
