-- The default scene (what `sandmpm run` runs without a scene file): a column of sand collapsing on
-- a sticky ground, in 3D. Column radius 0.1 m, height 0.4 m (height/radius 4, as in the thesis's
-- friction-angle scene), standing on y = 0. Sand of the thesis's Table 4.2: rho 2200 kg/m^3,
-- E 3.537e5 Pa, nu 0.3, hardening 35/9/0.2/10 (friction angle 25 deg at rest, peaking near 48,
-- settling at 35). 8 particles per cell, 24 frames per second, 30 frames (1.25 s).
-- Quality: preview dx = 15 mm (about 30 thousand particles), paper dx = 5 mm (about 0.8 million),
-- test dx = 40 mm and 2 frames. `--set dx=0.02` overrides the grid spacing.
local q = params.quality
local dx = params.dx or ({preview = 0.015, paper = 0.005, test = 0.04})[q]
return {
  dim = 3, dx = dx, ppc = 8,
  fps = 24, frames = (q == "test") and 2 or 30,
  max_dt = 1e-3,
  domain = { min = {-0.6, -0.05, -0.6}, max = {0.6, 0.5, 0.6} },   -- walls: "separate" (the default)
  materials = {
    sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, hardening = {35, 9, 0.2, 10} },
  },
  objects = {
    { shape = { type = "cylinder", center = {0, 0.2, 0}, radius = 0.1, height = 0.4 }, material = "sand" },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0, 0}, normal = {0, 1, 0} }, mode = "sticky" },
  },
  camera = { eye = {0.9, 0.6, 1.2}, target = {0, 0.12, 0}, up = {0, 1, 0}, fov = 40 },
}
