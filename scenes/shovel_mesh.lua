-- Shoveling with a mesh tool (issue 15): the shovel of scenes/meshes/shovel.obj (a curved blade
-- 0.26 x 0.3 m, 2 cm thick, with a 1 m shaft) digs into a bed of sand, lifts a load and carries it
-- away; the motion of scenes/shovel.lua (keyframes: in nose down, through the sand, tilted up,
-- lifted, carried sideways). The file's origin is the blade's tip: turned by -90 degrees about y
-- the blade points +x with the shaft behind it, and the keyframes' rotations (about z) pitch it
-- about its tip. Sand: rho 2200, E 3.537e5, nu 0.3, hardening 35/9/0.2/10. Shovel: separate,
-- friction 0.5.
local q = params.quality
local dx = ({paper = 0.005, preview = 0.013, test = 0.03})[q]
local floor = 0.02
local depth = 0.07
local s = floor + depth
return {
  dim = 3, dx = dx, ppc = (q == "paper") and 8 or 4,
  fps = 24, frames = (q == "test") and 2 or 132,
  max_dt = (q == "paper") and 1e-4 or 2.5e-4,
  domain = { min = {-0.45, 0, -0.25}, max = {0.45, 0.5, 0.25} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, hardening = {35, 9, 0.2, 10} },
  },
  objects = {
    { shape = { type = "box", center = {0, floor + depth / 2, 0}, half_extent = {0.42, depth / 2, 0.22} }, material = "sand" },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, floor, 0}, normal = {0, 1, 0} }, mode = "sticky" },
    { shape = { type = "mesh", file = "meshes/shovel.obj", axis_angle = {0, 1, 0, -90} },
      mode = "separate", friction = 0.5,
      keyframes = {
        { t = 0.0, position = {-0.10, s + 0.10, 0}, axis_angle = {0, 0, 1, -25} },
        { t = 1.0, position = {0.00, s - 0.035, 0}, axis_angle = {0, 0, 1, -20} },
        { t = 2.2, position = {0.25, s - 0.04, 0}, axis_angle = {0, 0, 1, -5} },
        { t = 3.0, position = {0.32, s + 0.01, 0}, axis_angle = {0, 0, 1, 12} },
        { t = 4.0, position = {0.32, s + 0.20, 0}, axis_angle = {0, 0, 1, 12} },
        { t = 5.5, position = {0.36, s + 0.25, 0.12}, axis_angle = {0, 0, 1, 12} },
      } },
  },
  camera = { eye = {0.6, 0.5, 0.7}, target = {0.1, 0.08, 0}, up = {0, 1, 0}, fov = 45 },
}
