-- Axisymmetric granular column collapse in 3D (Lube et al. 2004, Lajeunesse et al. 2004): a
-- cylinder of radius R0 and height H0 = a R0 on a horizontal base, released at once. Only the
-- quarter x >= 0, z >= 0 is simulated: the planes x = 0 and z = 0 are slip walls (frictionless,
-- the symmetry planes of the full column).
-- Parameters (--set KEY=VALUE):
--   a        aspect ratio H0/R0 (default 1)
--   n        cells across R0 (default 10; dx = R0/n)
--   R0       radius, m (default 0.05)
--   ppc      particles per cell (default 8)
--   phi, fit, base, base_mu, kernel, transfer, flip_ratio, elastic_cfl, T, fps_n, projection, sticks: as
--   collapse2d.lua
local P = params
local a = P.a or 1
local R0 = P.R0 or 0.05
local n = P.n or 10
if params.quality == "test" then n = math.min(n, 5) end
local dx = R0 / n
local H0 = a * R0
local tau = math.sqrt(H0 / 9.81)
local runout = (a < 1.7 and 1.24 * a or 1.6 * a ^ 0.5) * R0
local rmax = R0 + 1.6 * runout + 6 * dx
local base = P.base or "sticky"
local ground = { shape = { type = "halfspace", point = {0, 0, 0}, normal = {0, 1, 0} } }
if base == "sticky" then ground.mode = "sticky" else ground.mode = "separate"; ground.friction = P.base_mu or 0.5 end
local T = (P.T or (a < 1.5 and 8 or 5)) * tau
local fps = (P.fps_n or 4) / tau
return {
  dim = 3, dx = dx, ppc = P.ppc or 8,
  kernel = P.kernel or "quadratic", transfer = P.transfer or "apic", flip_ratio = P.flip_ratio or 0.95,
  elastic_cfl = P.elastic_cfl, -- nil: the program's default
  particle_projection = (P.projection == nil) and true or P.projection,
  static_friction_sticks = (P.sticks == nil) and true or P.sticks,
  fps = fps, frames = math.ceil(T * fps - 1e-9),
  domain = { min = {-4 * dx, -4 * dx, -4 * dx}, max = {rmax, H0 * 1.1 + 6 * dx, rmax} },
  materials = { sand = { model = "sand", density = 2200, E = 3.537e5, nu = 0.3, friction_angle = P.phi or 30,
                         cone_fit = P.fit or "triaxial_compression" } },
  objects = { { shape = { type = "cylinder", center = {0, H0 / 2, 0}, radius = R0, half_height = H0 / 2 },
                clip = { type = "box", center = {R0, H0 / 2, R0}, half_extent = {R0, H0, R0} } } },
  colliders = {
    ground,
    { shape = { type = "halfspace", point = {0, 0, 0}, normal = {1, 0, 0} }, mode = "slip" },
    { shape = { type = "halfspace", point = {0, 0, 0}, normal = {0, 0, 1} }, mode = "slip" },
  },
  outputs = { ply = true, vtk = false, csv = true },
}
