-- A mesh plough through sand (issue 15): the plough of scenes/meshes/plough.obj (a wedge share
-- 0.35 m long pointing -x, 12 cm high, and a 25 cm mouldboard curving to one side behind it) is
-- drawn through a bed of sand at 0.4 m/s, 4 cm deep: the share splits the bed, the mouldboard turns
-- the sand over to one side and leaves a furrow across the 0.8 m bed. In the file
-- z is up (0 .. 0.25 m) and the share's tip is the origin: turned by -90 degrees about x it stands
-- on its base, and `position` puts the tip.
-- Sand: rho 2200, E 3.537e5, nu 0.3, hardening 35/9/0.2/10. Plough: slip, friction 0.4.
local q = params.quality
local dx = ({paper = 0.005, preview = 0.012, test = 0.03})[q]
local floor = 0.02
local depth = 0.08
local base = floor + depth - 0.04            -- the plough's base, 4 cm into the bed
return {
  dim = 3, dx = dx, ppc = (q == "paper") and 8 or 4,
  fps = 24, frames = (q == "test") and 2 or 60,
  max_dt = 2.5e-4,
  domain = { min = {-0.6, 0, -0.3}, max = {0.6, 0.45, 0.3} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, hardening = {35, 9, 0.2, 10} },
  },
  objects = {
    { shape = { type = "box", center = {0, floor + depth / 2, 0}, half_extent = {0.4, depth / 2, 0.26} }, material = "sand" },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, floor, 0}, normal = {0, 1, 0} }, mode = "sticky" },
    { shape = { type = "mesh", file = "meshes/plough.obj", axis_angle = {1, 0, 0, -90},
                position = {0.45, base, 0} },
      mode = "slip", friction = 0.4, velocity = {-0.4, 0, 0} },
  },
  camera = { eye = {-0.2, 0.6, 0.8}, target = {0, 0.06, 0}, up = {0, 1, 0}, fov = 45 },
}
