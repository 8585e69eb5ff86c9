-- A heap built at rest and let go (2D): a wedge of sand against a slip wall at x = 0 (the heap's
-- symmetry plane), height H, flank at `slope` degrees, on a sticky plate; no stream, no impact.
-- Where the flank settles is the steepest slope the discretised material holds when it starts from
-- a steeper one: compared with the poured pile (pile.lua), it separates the stream's impact from
-- the resolution of the flank. Parameters: n (cells per 6 mm, default 4), H (0.03 m), slope (45),
-- phi (30), fit, ppc (4), transfer, projection, sticks, base/base_mu as pile.lua, T (0.6 s).
local P = params
local n = P.n or 4
if params.quality == "test" then n = math.min(n, 2) end
local dx = 0.006 / n
local H = P.H or 0.03
local th = math.rad(P.slope or 45)
local L = H / math.tan(th)
local ground = { shape = { type = "halfspace", point = {0, 0}, normal = {0, 1} } }
if (P.base or "sticky") == "sticky" then ground.mode = "sticky" else ground.mode = "separate"; ground.friction = P.base_mu or 0.7 end
return {
  dim = 2, dx = dx, ppc = P.ppc or 4,
  transfer = P.transfer or "apic",
  particle_projection = (P.projection == nil) and true or P.projection,
  static_friction_sticks = (P.sticks == nil) and true or P.sticks,
  fps = 10, end_time = P.T or 0.6,
  domain = { min = {-4 * dx, -4 * dx}, max = {3 * L + 0.02, H + 6 * dx} },
  materials = { sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, friction_angle = P.phi or 30,
                         cone_fit = P.fit or "triaxial_compression" } },
  objects = { { shape = { type = "halfspace", point = {0, H}, normal = {math.sin(th), math.cos(th)} },
                clip = { type = "box", center = {L / 2, H / 2}, half_extent = {L / 2, H / 2} } } },
  colliders = { ground, { shape = { type = "halfspace", point = {0, 0}, normal = {1, 0} }, mode = "slip" } },
  outputs = { ply = true, vtk = false, csv = true },
}
