/* The help texts of the program and its commands. */
#include "cli/cli.h"

void cli_usage(FILE *f) {
    fprintf(f, "sandmpm %s: dry sand with the Material Point Method (Klar 2016)\n\n"
               "usage: sandmpm COMMAND [ARGS]\n\n"
               "commands:\n"
               "  run [SCENE]     run a scene file (Lua); without SCENE the built-in default:\n"
               "                  a 3D sand column collapsing on the ground\n"
               "  info SCENE      print the resolved scene and estimate a run's time, disk and memory, without running it\n"
               "  render OUTDIR   turn a run's frames (OUTDIR/frame_NNNN.ply) into PNG images\n"
               "  bench           particle-steps/s per stage: 2D and 3D, float and double, 1 and 2 threads\n\n"
               "  --help          this text; `sandmpm help COMMAND` or `sandmpm COMMAND --help` for a\n"
               "                  command's options\n"
               "  --version, -V   version and precision\n\n",
            sm_version());
    cli_print_exit_codes(f);
    fprintf(f, "scene format: docs/scene-format.md\n");
}

void cli_usage_run(FILE *f) {
    fprintf(f, "usage: sandmpm run [SCENE] [OPTIONS]\n\n"
               "Runs SCENE (a Lua scene file, docs/scene-format.md), or without SCENE the built-in default\n"
               "scene: a sand column (radius 0.1 m, height 0.4 m) collapsing on a sticky ground.\n\n"
               "  --out DIR          output directory (default: out/NAME, NAME = the scene file's stem or \"default\")\n"
               "  --frames N         frames after frame 0 (default: the scene's)\n"
               "  --end SECONDS      simulated end time instead of --frames\n"
               "  --checkpoint-every N  write OUT/checkpoints/ckpt_FRAME.smc every N frames (default 20; 0: none)\n"
               "  --keep-checkpoints K  keep the last K checkpoints (default 2)\n"
               "  --resume           continue from the newest valid checkpoint in OUT (frames byte-identical)\n"
               "  --force            resume even if the scene file, --set values or --quality changed\n"
               "  --overwrite        replace another run's files in OUT (only those its run_manifest.txt lists)\n"
               "  --set KEY=VALUE    scene parameter, seen by the scene as params.KEY (repeatable)\n"
               "  --quality Q        preview (default), paper (the thesis's resolution) or test (tiny, for CI)\n"
               "  --threads N        threads of the step (default: the library chooses, up to all cores); results do not depend on it\n"
               "  --render           also render each frame to OUTDIR/frame_NNNN.png\n"
               "  --video            assemble OUTDIR/video.mp4 with ffmpeg at the end (renders the frames: implies --render)\n"
               "  -q, --quiet        no banner, progress line or summary (warnings and errors still)\n"
               "  -v, --verbose      a line per frame: its steps, dt range, largest speed, energy, Newton/GMRES\n\n"
               "Writes per frame (as the scene's outputs table says): frame_NNNN.ply (binary PLY),\n"
               "frame_NNNN.vtp with frames.pvd (VTK/ParaView), and diagnostics.csv; each file atomically\n"
               "(written as .NAME.tmp.PID, then renamed), so a file under its name is always whole.\n"
               "OUT/run_manifest.txt names the scene, its hash and the files written so far (docs/outputs.md).\n"
               "A folder holding another run's frames is refused (exit 2) unless --overwrite or --resume; an\n"
               "earlier run of the same scene (same file, --set values and quality) is replaced.\n\n"
               "Ctrl-C (SIGINT) or SIGTERM stops at the next step, keeps the last whole frame as a checkpoint\n"
               "and says which frames are complete (with --checkpoint-every 0: after the frame in progress);\n"
               "a second one stops at once (the files being written are removed). Temporaries\n"
               "that a killed run left are removed by the next run in the folder. A write that fails (a\n"
               "full disk, no permission) stops the run with exit code 4, the file and the reason.\n\n"
               "Under mpirun -np N (a build with MPI): the run spreads over N ranks, --threads each; rank 0\n"
               "writes the folder, the frame files are those of one process (README, \"Distributed runs\").\n");
}

void cli_usage_info(FILE *f) {
    fprintf(f, "usage: sandmpm info SCENE [--set KEY=VALUE]... [--quality preview|paper|test]\n\n"
               "Loads and builds SCENE without running it and prints: particles (estimated and seeded), the\n"
               "grid, the time-step bounds and frames; then steps the world for about a second (the probe)\n"
               "and estimates what `sandmpm run SCENE` will cost: run time (a range of steps times the\n"
               "probe's seconds per particle-step), disk (frames and kept checkpoints) and peak memory.\n"
               "A scene whose memory estimate exceeds this machine's memory is refused (exit 2) with the\n"
               "estimate in the message. docs/outputs.md, \"What a run costs\", says how each is estimated.\n");
}

void cli_usage_render(FILE *f) {
    fprintf(f, "usage: sandmpm render OUTDIR [--frames N|FROM..TO] [--color sand|speed|material|q] [--size WxH]\n"
               "                      [--threads N] [--video]\n\n"
               "Renders the OUTDIR/frame_NNNN.ply files that OUTDIR/run_manifest.txt lists (every one found\n"
               "in a folder without it) into OUTDIR/frame_NNNN.png: particles as lit\n"
               "spheres with shadows (disks in 2D), random brown tones (or colour by speed, material, or\n"
               "hardening q), the ground and the colliders (from OUTDIR/render.txt, written by `run`).\n"
               "  --color C    speed, q and material draw a legend (the colour map and its range, or the\n"
               "               materials' swatches) in the bottom-left corner\n"
               "  --size WxH   image size (default 1280x720)\n"
               "  --frames R   only frame N, or frames FROM..TO (FROM.., ..TO: open ends)\n"
               "  --video      assemble OUTDIR/video.mp4 with ffmpeg (if installed)\n"
               "Ctrl-C stops after the frame in progress; PNG files are written atomically.\n");
}

void cli_usage_bench(FILE *f) {
    fprintf(f, "usage: sandmpm bench [--dim 2,3] [--precision float,double] [--threads 1,2] [--particles N]\n"
               "                     [--steps S] [--warmup W] [--load N] [--csv [--no-header]]\n\n"
               "Measures the explicit step on a block of sand collapsing onto a sticky ground (hardening,\n"
               "quadratic kernel, APIC, every stage; 8 particles per cell in 3D, 4 in 2D): W warm-up steps,\n"
               "then S measured steps per case, one case per dimension, precision and thread count. Prints\n"
               "particle-steps/s in total and per stage, heap bytes per particle and heap allocations per\n"
               "step. This program is built in one precision (%s); the other runs in %s next to it.\n\n"
               "  --dim LIST         2, 3 or 2,3 (default 2,3)\n"
               "  --precision LIST   float, double or float,double (default float,double)\n"
               "  --threads LIST     thread counts, e.g. 1,2 (default 1,2); auto: the library chooses per step,\n"
               "                     as a run does by default (0 in the CSV's threads column)\n"
               "  --particles N      particles per case, about (default 1e6; at least 100)\n"
               "  --steps S          measured steps (default 20)\n"
               "  --warmup W         unmeasured steps before them (default 10)\n"
               "  --load N           run each case beside N busy processes (a shared machine; default 0)\n"
               "  --csv              one row per case: %s\n"
               "  --no-header        with --csv: no header line\n",
            sm_real_is_double() ? "double" : "float", SM_BENCH_SIBLING[0] ? SM_BENCH_SIBLING : "(none in this build)",
            "dim,precision,threads,particles,particle_steps_per_s,bytes_per_particle");
}
