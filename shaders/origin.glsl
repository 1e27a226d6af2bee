// Camera-relative rendering (engine/view.py): positions far from the world origin
// arrive as double-float pairs (hi + lo, split on the CPU in double precision) and
// are made relative to the frame's origin here: the camera's eye in the G-buffer and
// lighting passes, a light (or the sun's anchor) in the shadow passes. When both are
// near each other hi - origin_hi is exact (Sterbenz), so the result keeps float's
// relative precision about the origin, whatever the distance to the world origin.
uniform vec3 u_origin_hi;
uniform vec3 u_origin_lo;
vec3 rebase(vec3 hi, vec3 lo) { return (hi - u_origin_hi) + (lo - u_origin_lo); }
