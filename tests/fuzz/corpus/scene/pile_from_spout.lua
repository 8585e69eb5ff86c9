-- Pile from spout (thesis §4.1.2, Fig. 4.2): sand poured at a constant rate onto a high-friction
-- (sticky) surface builds a pile whose flanks avalanche. Needs an emitter.
-- Geometry (not given in the thesis; chosen for its 240x96x240 grid at dx = 0.83 mm): a spout of
-- radius 4 mm, 60 mm above the ground, pouring 20 g/s downward at 0.5 m/s for 2 s into a
-- 0.2 x 0.08 x 0.2 m domain (preview: pouring for 1.2 s, 1.33 s in all). Material: rho 2200, E 3.537e5, nu 0.3, friction angle 30 deg.
-- Implicit (Newton-GMRES) as in the thesis, at its max dt 1.5e-4 (--set explicit=true to compare).
local q = params.quality
local dx = ({paper = 0.00083, preview = 0.003, test = 0.005})[q]
local ppc = (q == "paper") and 32 or 8
local r = math.max(0.004, 2.5 * dx)
return {
  integrator = params.explicit and "explicit" or "implicit",
  dim = 3, dx = dx, ppc = ppc,
  fps = (q == "paper") and 120 or 30, frames = (q == "test") and 2 or ((q == "paper") and 300 or 40),
  max_dt = 1.5e-4,
  domain = { min = {-0.1, 0, -0.1}, max = {0.1, 0.08, 0.1} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, friction_angle = 30 },
  },
  emitters = {
    { shape = { type = "cylinder", center = {0, 0.066, 0}, radius = r, half_height = 0.004 },
      material = "sand", velocity = {0, -0.5, 0}, rate = 0.02, start = 0, stop = (q == "paper") and 2.0 or 1.2, ppc = ppc },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.006, 0}, normal = {0, 1, 0} }, mode = "sticky" },
  },
  camera = { eye = {0.12, 0.07, 0.12}, target = {0, 0.01, 0}, up = {0, 1, 0}, fov = 40 },
}
