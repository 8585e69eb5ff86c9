-- Castle (thesis §4.1.4, Fig. 4.4): an elastic ball hits a collapsing sand castle. Two materials in
-- one simulation, coupled through the shared grid: the ball is MPM with the elastic model.
-- Geometry (not given in the thesis; chosen for its 300x140x200 grid at dx = 1 cm, about 0.8
-- million particles at 8 per cell): a 0.7 x 0.15 x 0.7 m base, four corner towers (radius 8 cm,
-- 30 cm tall) and a 0.25 m keep on top; a ball of radius 0.15 m (rho 1000, E 1e5, nu 0.3) thrown
-- at 4 m/s at the castle from 1.2 m away. Sand: rho 2200, E 3.537e5, nu 0.3, hardening 35/0/0.2/10
-- (Table 4.2: phi starts at 25 deg and hardens to 35 deg). Sticky ground.
-- Implicit (Newton-GMRES) as in the thesis, at its max dt 1e-3 (--set explicit=true to compare).
local q = params.quality
local dx = ({paper = 0.01, preview = 0.04, test = 0.05})[q]
local g = 0.05   -- ground height
local cx, cz = 1.7, 1.0
local objects = {
  { shape = { type = "box", center = {cx, g + 0.075, cz}, half_extent = {0.35, 0.075, 0.35} }, material = "sand" },
  { shape = { type = "box", center = {cx, g + 0.15 + 0.1, cz}, half_extent = {0.125, 0.1, 0.125} }, material = "sand" },
}
for _, s in ipairs({{-1, -1}, {-1, 1}, {1, -1}, {1, 1}}) do
  objects[#objects + 1] = { shape = { type = "cylinder", center = {cx + 0.26 * s[1], g + 0.15 + 0.15, cz + 0.26 * s[2]},
                                      radius = 0.08, half_height = 0.15 }, material = "sand" }
end
objects[#objects + 1] = { shape = { type = "sphere", center = {cx - 1.2, g + 0.45, cz}, radius = 0.15 },
                          material = "ball", velocity = {4, 0.5, 0} }
return {
  integrator = params.explicit and "explicit" or "implicit",
  dim = 3, dx = dx, ppc = 8,
  fps = (q == "test") and 24 or 72, frames = (q == "test") and 2 or ((q == "paper") and 144 or 72),
  max_dt = params.max_dt or 1e-3,
  domain = { min = {0, 0, 0}, max = {3.0, 1.4, 2.0} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, hardening = {35, 0, 0.2, 10} },
    ball = { model = "elastic", density = 1000, E = 1e5, nu = 0.3 },
  },
  objects = objects,
  colliders = {
    { shape = { type = "halfspace", point = {0, g, 0}, normal = {0, 1, 0} }, mode = "sticky" },
  },
  camera = { eye = {0.6, 1.1, 2.6}, target = {1.5, 0.2, 1.0}, up = {0, 1, 0}, fov = 45 },
}
