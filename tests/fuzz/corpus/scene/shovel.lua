-- Shoveling (thesis §4.1.8, Fig. 4.12): a shovel blade digs into sand, lifts a load and moves it
-- away (large deformation).
-- Geometry (not given in the thesis; chosen for its 160x100x100 grid at dx = 5 mm, about 2 million
-- particles at 8 per cell): a bed of sand 0.8 x 0.07 x 0.5 m; a scoop (bottom plate 18 x 14 cm with
-- side and back walls 6 cm high) moved by keyframes: in at a nose-down angle, through the sand,
-- tilted up, lifted and carried sideways. Sand: rho 2200, E 3.537e5, nu 0.3, hardening
-- 35/9/0.2/10. Shovel: separate (sand may fall off but never passes through), friction 0.5.
local q = params.quality
local dx = ({paper = 0.005, preview = 0.015, test = 0.03})[q]
local th = math.max(0.008, 1.5 * dx)      -- plate thickness: at least 1.5 cells
local floor = 0.02
local depth = 0.07
local blade = {
  { type = "box", center = {0, 0, 0}, half_extent = {0.09, th / 2, 0.07} },
  { type = "box", center = {0, 0.03, 0.07}, half_extent = {0.09, 0.03, th / 2} },
  { type = "box", center = {0, 0.03, -0.07}, half_extent = {0.09, 0.03, th / 2} },
  { type = "box", center = {-0.09, 0.03, 0}, half_extent = {th / 2, 0.03, 0.07} },
}
local s = floor + depth
return {
  dim = 3, dx = dx, ppc = (q == "paper") and 8 or 4,
  fps = 24, frames = (q == "test") and 2 or 132,
  max_dt = (q == "paper") and 1e-4 or 2.5e-4,   -- preview: the elastic-wave bound limits dt anyway
  domain = { min = {-0.4, 0, -0.25}, max = {0.4, 0.5, 0.25} },
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, hardening = {35, 9, 0.2, 10} },
  },
  objects = {
    { shape = { type = "box", center = {0, floor + depth / 2, 0}, half_extent = {0.37, depth / 2, 0.22} }, material = "sand" },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, floor, 0}, normal = {0, 1, 0} }, mode = "sticky" },
    { shapes = blade, mode = "separate", friction = 0.5,
      keyframes = {
        { t = 0.0, position = {-0.30, s + 0.12, 0}, axis_angle = {0, 0, 1, -25} },
        { t = 1.0, position = {-0.20, s - 0.03, 0}, axis_angle = {0, 0, 1, -25} },
        { t = 2.2, position = {0.02, s - 0.035, 0}, axis_angle = {0, 0, 1, -8} },
        { t = 3.0, position = {0.10, s + 0.02, 0}, axis_angle = {0, 0, 1, 20} },
        { t = 4.0, position = {0.10, s + 0.20, 0}, axis_angle = {0, 0, 1, 20} },
        { t = 5.5, position = {0.15, s + 0.25, 0.12}, axis_angle = {0, 0, 1, 20} },
      } },
  },
  camera = { eye = {0.3, 0.45, 0.6}, target = {0, 0.08, 0}, up = {0, 1, 0}, fov = 45 },
}
