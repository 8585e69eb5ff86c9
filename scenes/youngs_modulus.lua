-- Young's modulus (thesis §4.1.3, Fig. 4.3), 2D: the same block of sand with E = 1e3, 1e4, 1e5,
-- 1e6 Pa (sandmpm run scenes/youngs_modulus.lua --set E=1e3; default 1e5). Low E is bouncy and
-- gelatin-like, high E behaves like sand.
-- Geometry (not given in the thesis; chosen for its 256x64 grid at dx = 0.016 with about 740
-- particles at 4 per cell): a 0.22 x 0.22 m block dropped from 0.3 m onto a sticky ground in a
-- 4.096 x 1.024 m domain. Material: rho 2200, nu 0.3, hardening 35/9/0.3/10.
-- Implicit (Newton-GMRES) as in the thesis, at its max dt 7.5e-4 (--set explicit=true to compare).
local q = params.quality
local E = params.E or 1e5
local dx = ({paper = 0.016, preview = 0.016, test = 0.032})[q]
return {
  integrator = params.explicit and "explicit" or "implicit",
  dim = 2, dx = dx, ppc = 4,
  fps = 24, frames = (q == "test") and 2 or 48,
  max_dt = params.max_dt or 7.5e-4,
  domain = { min = {0, 0}, max = {4.096, 1.024} },
  gravity = {0, -9.81},
  materials = {
    sand = { model = "sand", density = 2200, E = E, nu = 0.3, hardening = {35, 9, 0.3, 10} },
  },
  objects = {
    { shape = { type = "box", center = {2.048, 0.05 + 0.3 + 0.11}, half_extent = {0.11, 0.11} }, material = "sand" },
  },
  colliders = {
    { shape = { type = "halfspace", point = {0, 0.05}, normal = {0, 1} }, mode = "sticky" },
  },
}
