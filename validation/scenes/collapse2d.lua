-- Granular column collapse in 2D (plane strain), the experiment of Lube et al. 2005 and
-- Lajeunesse et al. 2005: a column of length L0 and height H0 = a L0 stands against a back wall
-- at x = 0 on a horizontal base and is released at once (no gate: at t = 0 it is stress free).
-- Parameters (--set KEY=VALUE):
--   a        aspect ratio H0/L0 (default 2)
--   n        cells across L0 (default 20; dx = L0/n)
--   L0       column length, m (default 0.05)
--   ppc      particles per cell (default 4)
--   phi      friction angle, degrees (default 30); fit: cone_fit name (default triaxial_compression)
--   base     "sticky" (default, the thesis's ground) or "friction" (Coulomb, mu = base_mu, default 0.5)
--   kernel, transfer   "quadratic"/"cubic", "apic"/"pic"/"flip"
--   flip_ratio         FLIP's share of the FLIP/PIC blend (default 0.95, the program's)
--   elastic_cfl        the explicit step's elastic Courant number (default: the program's, 0.6 since 2026-12-07)
--   T        simulated time in units of sqrt(H0/g) (default 5, 8 for a < 1.5: the front stops by about 3)
--   fps_n    frames per sqrt(H0/g) (default 4)
--   projection, sticks   sm_world_def's particle_projection / static_friction_sticks (default true)
-- The back wall is a slip half-space (frictionless), as smooth walls in the experiments; sand
-- rho 2200, E 3.537e5, nu 0.3 (the thesis's Table 4.2), fixed friction angle.
local P = params
local a = P.a or 2
local L0 = P.L0 or 0.05
local n = P.n or 20
if params.quality == "test" then n = math.min(n, 8) end
local dx = L0 / n
local H0 = a * L0
local g = 9.81
local tau = math.sqrt(H0 / g)
-- runout of the law of Lube et al. 2005 with a 60% margin sets the domain length
local runout = (a < 2.3 and 1.2 * a or 1.9 * a ^ (2 / 3)) * L0
local xmax = L0 + 1.6 * runout + 6 * dx
local base = P.base or "sticky"
local ground = { shape = { type = "halfspace", point = {0, 0}, normal = {0, 1} } }
if base == "sticky" then ground.mode = "sticky" else ground.mode = "separate"; ground.friction = P.base_mu or 0.5 end
local sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, friction_angle = P.phi or 30,
               cone_fit = P.fit or "triaxial_compression" }
local T = (P.T or (a < 1.5 and 8 or 5)) * tau
local fps_n = P.fps_n or 4
local fps = fps_n / tau
return {
  dim = 2, dx = dx, ppc = P.ppc or 4,
  kernel = P.kernel or "quadratic", transfer = P.transfer or "apic", flip_ratio = P.flip_ratio or 0.95,
  elastic_cfl = P.elastic_cfl, -- nil: the program's default
  particle_projection = (P.projection == nil) and true or P.projection,
  static_friction_sticks = (P.sticks == nil) and true or P.sticks,
  fps = fps, frames = math.ceil(T * fps - 1e-9),
  domain = { min = {-4 * dx, -4 * dx}, max = {xmax, H0 * 1.1 + 6 * dx} },
  materials = { sand = sand },
  objects = { { shape = { type = "box", center = {L0 / 2, H0 / 2}, half_extent = {L0 / 2, H0 / 2} } } },
  colliders = {
    ground,
    { shape = { type = "halfspace", point = {0, 0}, normal = {1, 0} }, mode = "slip" },
  },
  outputs = { ply = true, vtk = false, csv = true },
}
