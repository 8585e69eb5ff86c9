-- A pile poured from a spout onto a sticky plate (the thesis's pile-from-spout scene, §4.1.2,
-- made small enough to repeat): sand leaves a spout of half-width 4 mm, `drop` above the plate,
-- downward at `speed`, at 20 g/s in 3D for `pour` seconds, then rests for `rest` seconds. 3D
-- simulates the quarter x, z >= 0 (slip symmetry planes, 5 g/s); 2D the half x >= 0 (2 kg/(m s)).
-- Parameters (--set KEY=VALUE):
--   dim 3 | 2;  n: cells per 6 mm (default 4: dx = 1.5 mm, the issue's measurement);  ppc (8 / 4)
--   phi (30), fit (triaxial_compression), repose (instead of phi: repose_angle, degrees)
--   speed (0.5 m/s), drop (0.04 m), pour (1.0 s), rest (0.4 s)
--   base "sticky" (default) | "friction" (Coulomb, base_mu 0.7)
--   transfer, projection, sticks: as collapse2d.lua;  integrator "explicit" (default) | "implicit"
local P = params
local dim = P.dim or 3
local n = P.n or 4
if params.quality == "test" then n = math.min(n, 2) end
local dx = 0.006 / n
local drop = P.drop or 0.04
local speed = P.speed or 0.5
local pour, rest = P.pour or 1.0, P.rest or 0.4
local rs = 0.004
local sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, cone_fit = P.fit or "triaxial_compression" }
if P.repose then sand.repose_angle = P.repose else sand.friction_angle = P.phi or 30 end
local ground, spout, colliders, dmin, dmax
local width = dim == 3 and 0.06 or 0.1
if dim == 3 then
  ground = { shape = { type = "halfspace", point = {0, 0, 0}, normal = {0, 1, 0} } }
  spout = { type = "box", center = {rs / 2, drop, rs / 2}, half_extent = {rs / 2, 0.002, rs / 2} }
  colliders = { ground,
    { shape = { type = "halfspace", point = {0, 0, 0}, normal = {1, 0, 0} }, mode = "slip" },
    { shape = { type = "halfspace", point = {0, 0, 0}, normal = {0, 0, 1} }, mode = "slip" } }
  dmin, dmax = {-4 * dx, -4 * dx, -4 * dx}, {width, drop + 0.006 + 4 * dx, width}
else
  ground = { shape = { type = "halfspace", point = {0, 0}, normal = {0, 1} } }
  spout = { type = "box", center = {rs / 2, drop}, half_extent = {rs / 2, 0.002} }
  colliders = { ground, { shape = { type = "halfspace", point = {0, 0}, normal = {1, 0} }, mode = "slip" } }
  dmin, dmax = {-4 * dx, -4 * dx}, {width, drop + 0.006 + 4 * dx}
end
if (P.base or "sticky") == "sticky" then ground.mode = "sticky" else ground.mode = "separate"; ground.friction = P.base_mu or 0.7 end
local v = dim == 3 and {0, -speed, 0} or {0, -speed}
return {
  dim = dim, dx = dx, ppc = P.ppc or (dim == 3 and 8 or 4),
  integrator = P.integrator or "explicit", max_dt = 1.5e-4,
  transfer = P.transfer or "apic",
  particle_projection = (P.projection == nil) and true or P.projection,
  static_friction_sticks = (P.sticks == nil) and true or P.sticks,
  fps = 10, end_time = pour + rest,
  domain = { min = dmin, max = dmax },
  materials = { sand = sand },
  emitters = { { shape = spout, velocity = v, rate = dim == 3 and 0.005 or 2.0, start = 0, stop = pour } },
  colliders = colliders,
  outputs = { ply = true, vtk = false, csv = true },
}
