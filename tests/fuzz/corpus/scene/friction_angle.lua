-- Friction angle (thesis §4.1.1, Fig. 4.1; Tables 4.1, 4.2): a sand column with height/radius = 4
-- collapses on a no-slip (sticky) ground and piles; the higher the friction angle, the taller and
-- steeper the pile. One run per angle: sandmpm run scenes/friction_angle.lua --set angle=20
-- (20, 25, 30, 35, 40; default 30).
-- Geometry (not given in the thesis; chosen to fit its 432x144x432 grid at dx = 1 mm): column
-- radius 14 mm, height 56 mm, centred in a 0.432 x 0.144 x 0.432 m domain; about 1.1 million
-- particles at 32 per cell at paper quality. Material: rho 2200, E 3.537e5, nu 0.3, fixed angle.
local q = params.quality
local angle = params.angle or 30
local dx = ({paper = 0.001, preview = 0.0025, test = 0.007})[q]
local R, H = 0.014, 0.056
return {
  dim = 3, dx = dx, ppc = (q == "paper") and 32 or 8,
  fps = (q == "test") and 24 or 120, frames = (q == "test") and 2 or 60,
  max_dt = 1e-4, cfl = 1,
  domain = { min = {-0.216, 0, -0.216}, max = {0.216, 0.144, 0.216} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, friction_angle = angle },
  },
  objects = {
    { shape = { type = "cylinder", center = {0, 0.02 + H / 2, 0}, radius = R, half_height = H / 2 }, material = "sand" },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.02, 0}, normal = {0, 1, 0} }, mode = "sticky" },
  },
  camera = { eye = {0.16, 0.12, 0.16}, target = {0, 0.03, 0}, up = {0, 1, 0}, fov = 40 },
}
