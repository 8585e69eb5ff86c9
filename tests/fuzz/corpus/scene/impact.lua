-- High velocity impact (thesis §4.1.7, Fig. 4.11): a steel ball hits a sand bed at 6 m/s and throws
-- up a smooth, symmetric crown splash; the ball is an MPM body slowed by the sand, not a scripted
-- collider.
-- Geometry (not given in the thesis; chosen for its 256^3 grid at dx = 7.8 mm, about 6.6 million
-- particles at 9 per cell): a 2 x 2 m bed, 0.2 m deep, in a 2 m cube; a ball of radius 5 cm
-- starting 5 cm above the surface. Sand: rho 1582, E 3.537e6, nu 0.3, friction angle 22 deg. Ball:
-- rho 7800; E 5e7 (steel's 2e11 would only shrink the time step: at 6 m/s the ball hardly deforms
-- either way). Sticky container floor, slip walls.
local q = params.quality
local dx = ({paper = 0.0078, preview = 0.015, test = 0.04})[q]
local L = (q == "paper") and 2.0 or 0.6       -- the preview bed is smaller: same crater, less sand
local depth = (q == "paper") and 0.2 or 0.12
local r = 0.05
return {
  dim = 3, dx = dx, ppc = (q == "paper") and 9 or 8,
  fps = (q == "test") and 24 or 240, frames = (q == "test") and 2 or 96,
  max_dt = 5e-5,
  domain = { min = {-L / 2, 0, -L / 2}, max = {L / 2, depth + 0.5, L / 2} },
  materials = {
    sand = { model = "sand", density = 1582, E = 3.537e6, nu = 0.3, friction_angle = 22 },
    steel = { model = "elastic", density = 7800, E = 5e7, nu = 0.3 },
  },
  objects = {
    { shape = { type = "box", center = {0, 0.03 + depth / 2, 0}, half_extent = {L / 2 - 3 * dx, depth / 2, L / 2 - 3 * dx} },
      material = "sand" },
    { shape = { type = "sphere", center = {0, 0.03 + depth + r + 0.05, 0}, radius = r }, material = "steel",
      velocity = {0, -6, 0} },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.03, 0}, normal = {0, 1, 0} }, mode = "sticky" },
  },
  camera = { eye = {0.5 * L, 0.45, 0.8 * L}, target = {0, 0.15, 0}, up = {0, 1, 0}, fov = 40 },
}
