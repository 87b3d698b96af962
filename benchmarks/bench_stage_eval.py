"""Cost of the HFB-320 output-error fit (cases/hfb320 case 1: 601 samples, 11
parameters, nonlinear longitudinal model; with --case, of the C-8 short
period's fit (cases/c8_short_period case 2, on the record its case 1 makes),
ATTAS lateral's (cases/attas_lateral case 1), one of the flight-path
reconstructions that state their model as equations (cases/flight_path tc22,
tc32, tc33), or of all six) in this
build and, with --baseline DIR, in another build's mlid package (DIR holds
its `mlid` folder, e.g. main's .venv/lib/python3.11/site-packages), as
  - callgrind instruction counts of N fits inside the core's mlid_fit
    (repeatable on a shared machine), per fit and per sample and iteration;
  - the calls of malloc, calloc and realloc inside mlid_fit per fit (from
    the same callgrind run: what the per-sample loops allocate shows here);
  - wall-clock medians and least CPU times of in-process fits, the builds'
    processes taking turns round by round so that the machine's load falls
    on both (the least CPU time of many fits is the one least disturbed by
    the other processes' contention for the core and its caches: the
    steadiest figure of a shared machine's).
Two builds cannot be loaded into one process (one module name), hence
processes.  Needs valgrind for the first two (skipped without it).

    .venv/bin/python benchmarks/bench_stage_eval.py [--baseline DIR] [--fits N]
        [--case hfb320|c8|attas_lat|all]

Measured (ours, branch stage-eval against main at afd597e, one thread):
230.9 M -> 138.5 M instructions per fit (54.9 k -> 32.9 k per sample and
iteration, 7 iterations), 7248 -> 2464 allocations per fit (averaged over 3
fits: the 4800 of the per-step noise array are gone; what is left is
outside the per-sample loops, in the information matrix's eigensolver, the
coloured-residual correction, Newton); wall clock 46.2 -> 32.8 ms on a
loaded machine (the processes alternating), where main alone took 14.7 ms
when quiet.  Every case deck's results are unchanged to the bit.

Measured (ours, branch hfb-speed against main at 67d9318, one thread, the
steps in its commits): 133.0 M -> 102.5 M instructions per fit (31.6 k ->
24.4 k per sample and iteration): the RK4 stage product A S by a fixed-size
4 x 4 kernel called straight from the stage (1,400 -> 357 instructions per
call), the forcing and the outputs' C S at fixed sizes, the stage's blocks
without descriptors; the longitudinal model's coefficient gradients and
df/dp columns from their one nonzero each and no memset calls (al_eval
1,416 -> 1,090 instructions per point); the coloured-residual bracket's
FFT stages and G = K A with their loops reordered or fused, only the
padding zeroed (fft_forward 10.5 -> 9.6 M, the G loop 4.6 -> 3.8 M per
fit).  Least CPU time 10.3-10.5 -> 8.5-8.8 ms per fit (two runs of 5 and 7
rounds; wall medians 16.6-17.2 -> 10.2-12.7 ms, the machine loaded).  The
issue's 3 ms stays out of reach this way: what is left is spread thin (of
the instructions, the model's points 25 % with their sincos, the RK4 stages'
products and bookkeeping besides them 24 %, the coloured-residual correction
20 %, the outputs' sensitivities 9 %, the information's rank-k update 6 %).  Every case deck's results are unchanged
to the bit (benchmarks/compare_cases.py: 40 of 40 bitwise).

Measured (ours, branch hfb-eval against main at d84cbd5, one thread, the
steps in its commits; --case all --rounds 7 on a loaded machine):
  HFB-320    102.5 M -> 93.4 M instructions per fit (24.4 k -> 22.2 k per
             sample and iteration); least CPU time 8.52 -> 7.73 ms per fit
             (wall medians 38.3 -> 33.3 ms: the machine's other work);
  C-8        10.4 M -> 10.0 M (6.94 k -> 6.64 k); 1.05 -> 1.03 ms CPU;
  ATTAS lat. 206.4 M -> 203.6 M (19.6 k -> 19.4 k); 18.0 -> 17.6 ms CPU.
The HFB-320 steps: the model interface's eval takes x and its results at
explicit shapes (every kind, the user template): no array descriptors per
point (the model's own instructions 21.0 -> 17.2 M per fit, the stages'
call sites fewer too); the weighted sensitivities of the information at
explicit shapes and a diagonal R^-1's cost without matmul; RK4's state stages through the stage
kernels and the work arrays' sizes checked without shape arrays; the
outputs' C S of seven outputs by a fixed-size kernel.  Tried and dropped
(no gain or a loss in instructions): the outputs' dh/dp forcing through
add_forcing (it then stops being inlined in the stages), a stage product
with the forcing fused into it (a branch per column), the coefficients
summed in registers, df/dx written straight into a (two calls of the
kernels instead of one inlined).  Left: the arithmetic of the stages
(A S, the forcing, the stage points: SSE2 in the portable build, some
30 instructions a 4 x 4 column), the model's sincos (two per stage, three per sample: the compiler
already pairs each angle's sin and cos), the coloured-residual correction
(about 20 %).  The issue's 3 ms stays out of reach without changing the
sums (every case deck's results are unchanged to the bit:
benchmarks/compare_cases.py, 40 of 40 bitwise).

Measured (ours, branch aero-eval against main at e34fe4f, one thread; the
longitudinal model's point, fortran/models/mlid_aero_long.f90, alone):
  HFB-320    82.8 M -> 80.3 M instructions per fit (19.7 k -> 19.1 k per
             sample and iteration): al_eval 17.2 M -> 14.7 M self (the
             sincos calls unchanged, 4.5 M); a stage's point (f, df/dx,
             df/dp) 769 -> 662 instructions, a sample's (with h, dh/dx,
             dh/dp) 1,239 -> 1,051 (a driver of the model alone at the
             deck's parameters, callgrind); 3343 -> 3341 allocations per
             fit; least CPU time 7.65 -> 6.95 ms (wall medians 15.8 -> 12.1
             ms: one --rounds 3 run on a loaded machine, noisy);
  C-8, ATTAS lateral: unchanged (9.0 M, 158.1 M: other models).
The steps: each parameter's place in the point's coefficients and the
state equation it forces looked up once at creation (a flat loop of
fixed-index sums: no coefficient lookup or branch per parameter, the
terms of a regressor without gradient summed into a row never read);
the constants' products (rho/2, (S/m) rho, ...) and (S/m) qbar, (S cbar/Iy)
qbar formed once, each as before; df/dx straight into a; c column by
column; dh/dp's columns by coefficient (C_m on qdot, C_D and C_L on a_x
and a_z), zeros written once; the coefficients' zeroing in two halves
(gfortran's rep stos for the whole costs an instruction an entry); the
sines and cosines first (fewer values live across the calls).  Tried and
dropped: df/dp and dh/dp in one pass over idx (with the optional
arguments tested per column it costs the stages more than it saves the
samples; written out per case it saves 0.2 M a fit for three copies of
the loop), the outputs' sincos moved first, xdot written straight (the
rates then stop being inlined).  Left: the per-parameter loops (some 15
instructions a parameter for the coefficients and for each df/dp column,
20 for each dh/dp column: loads of the index tables, zero stores), the
interface's descriptors (some 50 instructions a point), sincos (rounding:
sin(alpha + sigma) from sin alpha, saving a sample's third sincos, would
change every fit's last bits for some 0.4 M a fit).  Every case deck's
results are unchanged to the bit (benchmarks/compare_cases.py: 40 of 40
bitwise; HFB-320's four cases among them).

Measured (ours, branch colored-cut against main at e34fe4f, one thread;
--case all --rounds 3 on a loaded machine, load average 4-5):
  HFB-320    82.8 M -> 81.1 M instructions per fit (19.7 k -> 19.3 k per
             sample and iteration); least CPU time 7.15 -> 6.86 ms;
  C-8        9.0 M -> 8.9 M; 0.99 -> 0.99 ms CPU;
  ATTAS lat. 158.1 M -> 154.3 M (15.0 k -> 14.7 k); 14.2 -> 16.1 ms CPU
             (noise: the correction alone, 200 calls in turn, least of
             six runs: 8.76 -> 8.52 ms; HFB-320's 1.73 -> 1.50 ms).
All of it in the coloured-residual correction (benchmarks/bench_colored.py:
colored_covariance 9.43 -> 7.73 M per HFB-320 fit, 26.27 -> 22.40 M per
ATTAS fit), by its instructions around the arithmetic (the steps below
counted by a driver, not kept, calling colored_covariance once on each
fit's inputs: HFB-320 9.44 -> 7.76 M, ATTAS 26.28 -> 22.44 M):
fft_real_many's rows scaled and packed by explicit loops (a fixed length
for a full block of 16 rows) and unpacked with the scaling undone in the
same pass (-0.83 M, -2.38 M), both series of a complex transform from one
pass over it (-0.13 M, -0.36 M); G = K A two kernel rows a pass, its
first pass taking three (or two) columns without storing and reloading G
(-0.24 M, -0.68 M); the kernel's rows written in place, the
autocovariance's back-transforms divided only at the lags kept, its
cross-spectra made, sized and mirrored in one loop each (-0.47 M,
-0.42 M).  Every case deck's results are unchanged to the bit
(benchmarks/compare_cases.py: 40 of 40 bitwise; the same JSON with 1 and
2 threads).  Tried and dropped: the first radix-4 stage at a fixed length
(-0.02 M, -0.07 M), the gather of the parameters' rows in other loop
orders (more), odd transform lengths (675 points for HFB-320's 661:
-0.18 M, but sigma corrected moves by up to 8e-11 relative; ATTAS keeps
1728), blocks of 16 complex series (-0.1 M, -0.3 M; other pairs, other
rounding), radix-3 butterflies without twiddles at j = 0 (-0.44 M on
ATTAS, where radix 3 is the last stage; it needs a variant in each of
the four stages, and is exact but for the sign of zero).  Left: the
stages (2.96 M of HFB-320's 7.76 M: some 75 SSE2 instructions per
radix-4 butterfly of two series where its loads, stores and arithmetic
are some 50, gcc reloading inputs for want of registers), G = K A
(1.67 M), the bracket's dot products in linalg's add_sym_atb (0.84 M;
5.5 M on ATTAS, its largest part).

Measured (ours, branch lti-vec against main at e34fe4f, one thread; --case
all --rounds 3 on a loaded machine): the linear model's fast path
(mlid_lti_predict) sample by sample instead of products over blocks: the
sensitivities kept transposed s(c, i) and summed four rows at a time in
vector registers (the forcing, the recursion and C s each in the order the
block products summed), dy zeroed per sample in one piece (the 5-double
memset per column and sample is gone), the dC, dD and bias terms by
precomputed places; the states and outputs likewise (gemm gone); nx by
value so that 2 and 4 states make unrolled clones:
  ATTAS lat. 158.1 M -> 122.4 M instructions per fit (15.0 k -> 11.6 k per
             sample and iteration); lti_segment inclusive 66.6 M -> 30.8 M;
             least CPU time 15.1 -> 13.2 ms;
  C-8        9.0 M -> 7.4 M (6.0 k -> 4.9 k); 1.00 -> 0.93 ms CPU;
             benchmarks/monte_carlo_10k.py on two cores 6.1-6.4 s -> 5.5 s,
             the same estimates;
  HFB-320    82.8 M both (not this path).
Tried and dropped: the rows by pairs (the compiler vectorized the short
sums over the columns instead, in order, scalar: more instructions), the
forcing's kernel as a clone for fixed nx (it then lost its vectorization).
Not in this file: _gfortran_spread (2.3 M per ATTAS fit) is mlid_linalg's
eig_inverse (spread in its rank-one sums and scalings).  memset 5.2 M ->
2.1 M per ATTAS fit: left, dy's zeroing once per sample (0.85 M) and
segment_information's (mlid_likelihood, 0.8 M).  Every case deck's
results are unchanged to the bit (compare_cases: 40 of 40 bitwise).

Measured (ours, branch info-acc against main at e34fe4f, one thread;
--case all --rounds 3, twice; the output-error gradient and information's
accumulation, mlid_likelihood and mlid_linalg only):
  HFB-320    82.8 M -> 81.3 M instructions per fit; least CPU time 7.05 ->
             6.68 ms and 7.58 -> 7.10 ms (two runs, the machine loaded);
  C-8        9.0 M -> 8.9 M; 0.99 -> 0.98-0.99 ms CPU;
  ATTAS lat. 158.1 M -> 145.7 M (15.0 k -> 13.9 k per sample and
             iteration); CPU 15.3 -> 14.8 ms in one run, 11.7 -> 14.5 ms in
             the other (a test run beside it: noise, not the build).
Every case deck's results are unchanged to the bit (compare_cases: 40 of
40 bitwise; ATTAS and the three-manoeuvre tc23 the same JSON with one and
two threads).  The sums are the same; what is cheaper is the bookkeeping
around them (callgrind, per ATTAS fit): segment_information 54.3 -> 42.5 M
inclusive, 25.7 -> 17.0 M self: the exact scan for the (output, column)
pairs that move, four samples a test (3.8 -> 2.4 M); the weighted
sensitivities wsens written by the gather from the same load, at 64-bit
offsets worked out once a segment (gather, its tiles' padding and
weigh_row 18.9 -> 12.6 M; its loops unrolled by four); wsens zeroed only
where nothing moves, in a loop of explicit shape (3.3 -> 1.5 M); each
output's tile block allocated and padded once a segment; sym_atb_t 27.6 ->
24.9 M (the upper triangle only, mirrored once by add_output; the tiles'
sample loop unrolled by two: 37 -> 35.5 instructions a 4 x 4 tile and
sample).  HFB-320: dot8 7.6 -> 7.0 M (its loop unrolled by two, the same
eight partial sums), the stacked path's gradient as the product's last
column (one add_syrk, no add_atv), weigh_block writing wsens from the same
load (segment_information's own and its helpers' 5.2 -> 4.3 M).  Tried
and dropped: two dot products sharing y's loads (dot8x2, the same sums:
gfortran 12 vectorizes it across the partial sums, 2.6 times dot8's
instructions); the dense path by the 4 x 4 tiles on each output's
transposed gather (the stacked gather's tile count): HFB-320 85.8 M
against 81.9 M per fit, C-8 9.40 M against 8.94 M, so dot8 stays; a
symmetric diagonal tile (44 instructions a sample against 37); zeroing
wsens a column at a time (one large memset each: memset's count 14.7 M ->
30.9 M over three ATTAS fits); weigh_block's samples in runs per output or
its outputs unrolled (no gain, or a loss).  Left: the tile kernel at about
2.2 instructions per multiply-add (SSE2: the portable build); the gather
at about 13 instructions an entry with wsens (two stores each); mlid_newton
asks for wsens at every full evaluation though the coloured correction
uses the last one only (its writes and zeros about 5 M per
ATTAS fit, 2.3 M per HFB-320 fit), outside these files.

Measured (ours, branch tiles against main at da56406, one thread; --case
all --rounds 3 and 7; mlid_linalg's sym_atb_t only):
  HFB-320    76.6 M -> 76.6 M instructions per fit (the stacked path, dot8:
             untouched); least CPU time 6.38 -> 6.33 ms (noise);
  C-8        7.1 M -> 7.1 M; 0.89 -> 0.89 ms CPU;
  ATTAS lat. 103.3 M -> 97.4 M (9.83 k -> 9.26 k per sample and
             iteration); least CPU time 11.82 -> 11.29 ms and 11.73 ->
             11.46 ms (two runs, the machine shared).
sym_atb_t 24.9 -> 19.0 M per ATTAS fit (callgrind, 1,080 calls a fit: five
outputs of 14, 14, 19, 14, 14 columns, 64-sample blocks).  The tiles go by
pairs of columns, down to the diagonal in one to four pairs of rows: each
sample's y pair loaded once and swapped once (one shufpd), then one mulpd
and addpd for each half of a 2 x 2 block, where the 4 x 4 tile broadcast
each y value (two instructions each in SSE2); the triangle in 2 x 2 blocks
(14 columns: 112 products a sample where the 4 x 4 and 4 x 2 tiles made
128).  Inner loops (objdump, per sample): four pairs of rows 28.75
instructions for 16 multiply-adds (was 36.5 the 4 x 4 tile), three 22.75,
two 16.75, one 9.75; the floor of this scheme in two-operand SSE2 is three
instructions a product pair (copy, mulpd, addpd) plus the loads and the
swap: 26.5 for four pairs.  The same products summed in the same order:
every case deck bitwise (compare_cases: 40 of 40; ATTAS and tc23 the same
JSON with one and two threads).  Tried and dropped: wider tiles (five or
six pairs of rows, 4 x 6, 6 x 4: twelve accumulators spill); 4 x 4 tiles
of the same swapped pairs with a triangular diagonal tile (220 against 213
loop instructions a sample for 14 columns); a swapped copy of the y
rows made once (three array pointers: no fewer instructions); the kernels
without !GCC$ novector (gfortran 12 then swaps every x pair too: 32.75 a
sample for four pairs); unrolling by 2 or 8 (29.5, 28.4); the blocks added
to b as vector pairs (more instructions).  Native build (-march=native,
the kernels alone): 12 % faster than main's tiles, but the one-pair kernel
is not contracted to FMA where the others are, so its results differ from
main's native build at rounding level (the portable build is the target
and is bitwise).  Left: the odd column count's padding column (half the
products of its last pair of columns, 2-3 % of sym_atb_t in ATTAS)
and the per-call bookkeeping (calls, zeroing, adding the blocks to b:
about 10 % of sym_atb_t at 64 samples a block).

Measured (ours, branch wsens-once against main at da56406, one thread;
--case all, callgrind of 3 fits, timing two runs of --rounds 9 on a
loaded machine):
  ATTAS lat. 103.3 M -> 96.9 M instructions per fit (9.83 k -> 9.22 k per
             sample and iteration), 3486 -> 3475 allocations; least CPU
             time 11.54 -> 11.06 ms and 9.55 -> 8.62 ms;
  HFB-320    76.6 M -> 75.5 M (18.2 k -> 18.0 k), 2559 -> 2478
             allocations; 6.22 -> 6.04 ms and 6.04 -> 6.25 ms CPU (the
             1.4 % in instructions is below this machine's noise);
  C-8        7.1 M -> 7.0 M, 1942 -> 1913 allocations; 0.90 -> 0.87 ms and
             0.89 -> 0.88 ms.
The weighted sensitivities wsens of the coloured-residual correction are
made once per fit, at its estimate, from what the last accepted full
evaluation kept (mlid_likelihood's sens_keep_t: the sensitivities, which
every evaluation makes anyway, and R^-1, or filter error's B(j)^-1), not
written and zeroed by the information's gather at every evaluation; the
kept arrays are the next evaluation's (allocated once a fit for the
iterate and once for the trial, not at each evaluation).  Per ATTAS fit:
segment_information with its scan 17.0 M -> 9.6 M (6.9 M, and the scan,
no longer inlined, 2.7 M), the one weighing at the end 0.94 M; per
HFB-320 fit: weigh_block 4.2 ->
2.9 M, the weighing at the end 0.29 M (its loops over seven outputs cost
about 6 instructions an entry).  M2/F3 filter error (mlid run, all its
cases): 1641.6 -> 1639.8 M (its wsens was a copy of products made
anyway).  Every case deck's results are unchanged to the bit
(compare_cases: 40 of 40 bitwise; tc33 and hfb320 the same JSON with one
and two threads).  Left: weigh_block's own loop (the stacked path's
L' dy, about 7 instructions an entry).

Measured (ours, branch py-overhead against main at da56406, one thread;
--case all --rounds 3 --wrapper): the Python around the core call
(python/mlid only; the core untouched, its counts the same):
  HFB-320    4.49 M -> 0.67 M instructions per fit; timed, 0.51 -> 0.17 ms
             and 0.69 -> 0.26 ms (least of 3 x 20, two runs, the machine
             loaded);
  C-8        4.17 M -> 0.61 M; 0.42 -> 0.11 ms and 0.42 -> 0.105 ms (of
             a 0.90 -> 0.56 ms CPU fit);
  ATTAS lat. 5.04 M -> 0.84 M; 0.60 -> 0.23 ms and 0.88 -> 0.41 ms.
The same Python with the core call stubbed (its answer replayed) takes
60-80 us on all three: the rest is the caches and branch predictors the
core's run leaves cold, the more so the longer it runs.  The steps: the
core's option arrays kept by the (name, text) pairs given (the core set
each option and read every one back, about 40 f2py calls a fit; an error
is never kept, the message the core's); the manoeuvre map and the parsed
ties kept by the layout (ATTAS: 10 mlid_tie_parse calls a fit); the fit
outcome and stop reason kept; a FitResult's model, manoeuvres and
param_units made when first asked for, from a copy of the model and the
record's units taken at the fit (the units alone were 75-95 us); labels
for the free parameters only.  evaluate() and simulate() share the
helpers: C-8 0.30 -> 0.11 ms and 0.13 -> 0.06 ms.  f2py's own argument
handling (its routine less mlid_fit) is 61 k, 86 k and 129 k instructions
per fit, nothing copied (the arrays go in Fortran-ordered float64): left
as it is.  The allocation counts inside mlid_fit differ (1942 -> 1924 per
C-8 fit) only by glibc realloc moving or not with the heap Python left.
Monte Carlo (benchmarks/monte_carlo_10k.py, two cores): 3.2-4.2 s both,
the runs being the core's (mlid_monte_carlo), one wrapper call a chunk.
Every case deck's results are unchanged to the bit (compare_cases: 40 of
40 bitwise; the same with one and two threads).

Measured (ours, branch lti-sens against main at da56406, one thread; the
linear model's fast path, fortran/estimation/time_domain/mlid_lti_predict.f90, only; callgrind
per fit, --case all):
  C-8        7.1 M -> 5.4 M instructions per fit (4.71 k -> 3.58 k per
             sample and iteration): the sensitivities 2.89 -> 1.53 M
             (1,600 -> 850 instructions a sample), lti_segment 0.66 ->
             0.43 M; least CPU time 0.89-0.90 -> 0.82 ms per fit (three
             runs of 5-7 rounds); the C-8 Monte Carlo (monte_carlo_10k's
             10,000 fits, two cores, three alternating runs) 4,873 -> 5,566
             fits per CPU-second at the least CPU time (2.05 -> 1.80 s),
             the same estimates to the last digit;
  ATTAS lat. 103.3 M -> 98.8 M (9.83 k -> 9.40 k): the sensitivities and
             their forcing 23.7 -> 20.8 M (1,750 -> 1,540 a sample),
             lti_segment 5.1 -> 4.1 M, memcpy 2.2 -> 1.9 M (the forcing's
             copies into z gone); least CPU time per fit no change beyond
             the noise (six runs of 5-11 rounds: 9.9/9.8, 11.9/12.3,
             11.1/9.4, 11.2/11.7, 11.5/11.5, 11.5/10.1 ms this/main, load
             average 1.5-3); the fast path alone in a scratch program
             (lti_segment with sensitivities, ATTAS's sizes, 4.5 M
             samples, alternating): 0.51-0.60 -> 0.44-0.50 s user time
             (C-8's sizes: 0.35 -> 0.24 s);
  HFB-320    76.6 M both (not this path).
The sums and their terms' order are the same (every case deck's results
unchanged to the bit: compare_cases, 40 of 40 bitwise; ATTAS and C-8 the
same JSON with one and two threads; a scratch program comparing this
file's lti_segment with main's on 400 random linear models, one to six
states, held and linear inputs, one to three RK4 steps, one or two
segments: yhat, dy and the states equal to the bit). The steps: the
states' sensitivities kept by column, s(:, c), and summed GROUP = 4 states
at a time as one vector (gcc 12 keeps such sums in registers when the
state count is a constant: clones for one to four states; the row strips
of the transposed form summed padding rows, C-8's five live columns eight
rows); for one or two states the forcing of all live columns as one
vector, eight rows at a time with each z(l) loaded once as a pair of lanes
(ATTAS's forcing 9.2 -> 7.2 M), then Phi s by column; z handed over
without copies, dy zeroed only over the columns C s does not write (none
for C-8), C s's places in dy as 64-bit offsets; the states likewise as one
vector sum (lti_segment). Tried and dropped: the row-strip form with every
state's sums in registers (gcc 12 left the sums scalar once it unrolled
the loop over x: no gain on an ATTAS-sized scratch case), paired-lane
remainders of the forcing (gcc then split the main loop's pairs), C s
fused column by column (C reloaded: +220 a sample on the scratch case),
the u loop unrolled by four (a loss). Five or more states go through whole
groups and a remainder of constant size (8 % more than main's count in a
five-state scratch case: 4,770 against 4,420 a sample). Left: C s (ATTAS
430 a sample: 36 instructions a live column for five outputs, three of
them the sums' "0 +"), the dC, dD and bias terms (200 a sample on ATTAS:
about eleven instructions a term), the outputs' strips in lti_segment.

Measured (ours, branch hfb-outputs against integ34 at 85d78a0 = main at
da56406 with tiles and wsens-once, one thread; callgrind of 3 fits;
CPU: least thread time of 40 fits, six processes of each build taking
turns, a shared machine):
  HFB-320    75.5 M -> 70.3 M instructions per fit (17.96 k -> 16.72 k per
             sample and iteration; main 76.6 M); least CPU time 6.62 ->
             6.18 ms (bench_stage_eval --rounds 7: 6.60 -> 5.86 ms, its
             wall medians 6.38 -> 6.61 ms: noise);
  C-8        7.0 M -> 6.9 M;
  ATTAS lat. 91.0 M -> 90.1 M (add_sym_atb in the coloured correction);
             least CPU time 10.50 -> 10.46 ms (noise).
Per HFB-320 fit: the outputs' sensitivities (output_rows with small_product)
7.6 M -> 4.9 M (1,590 -> 1,025 instructions a sample): seven outputs of
four states with the model parameters the first columns (pm%cm = 1, 2, ..)
make each column of C S and add its w d column in one pass at fixed sizes
(product_7x4_add, about 76 instructions a column for 35 multiply-adds;
its own inner loop is two-operand SSE2's floor for a 7 x 4: the b
broadcasts, the row 7 in scalars), no second pass through dy with
descriptors; output_rows' own descriptor and check code is the 0.9 M left.
The stacked path's L' dy (weigh_block_7, seven rows at a fixed size, L's
diagonal in registers) 2.9 M -> 1.3 M (7.2 -> 3.2 instructions an entry).
The stacked syrk (sym_atb: dot8 for each entry of the triangle) 7.0 M ->
6.3 M: a row of the triangle six (dot8_6) or three (dot8_3) entries at a
time, dot8's partial sums a pair at a time over all the rows (one vector
register each column), x's pair read once for the columns: 1.76
instructions a multiply-add for six (standalone callgrind, m = 448, n =
12), 2.14 for three, dot8 alone 2.35; rows in blocks of 512 so the four
passes stay in L1 for long columns.  The same sums in the same order:
every case deck bitwise (compare_cases: 40 of 40; all 24 decks' JSON the
same with one and two threads); tests to the bit: product_7x4_add against
small_product then the columns added, add_sym_atb against dot8's order
written out (n 1..13, m 1..1109).  Tried and dropped: dot8's eight sums
for three columns at once (gfortran 12 goes scalar or shuffles: slower),
four partial sums a pass (twelve accumulators for six columns spill:
2x the instructions); columns in pairs for C S (the strided stores and
the pairs of b cost as much as the broadcasts).  Left: the triangle's
short rows (three and one entries: about 2.5 M of the 6.3 M), output_rows'
per-call checks (pm%cm = 1, 2, .. tested each sample; a flag in
param_map_t would drop it, outside these files).

Measured (ours, the five branches above merged with the review's fixes
and python/mlid/heap.py, against main at da56406, one thread; --case all
--rounds 7 on a quiet spell):
  HFB-320    76.6 M -> 70.4 M instructions per fit, 2559 -> 2389
             allocations; wall 6.82 -> 5.28 ms (median of 7 processes'
             medians), CPU 6.21 -> 5.10 ms (least of 7 x 20); the Python
             around the core 0.57 -> 0.18 ms;
  C-8        7.1 M -> 5.2 M, 1942 -> 1895; wall 0.94 -> 0.50 ms, CPU 0.89
             -> 0.47 ms; Python 0.41 -> 0.11 ms;
  ATTAS lat. 103.3 M -> 85.7 M, 3486 -> 3332; wall 12.38 -> 6.92 ms, CPU
             11.65 -> 6.63 ms; Python 0.66 -> 0.28 ms.
Before heap.py, the same build's least CPU time varied from process to
process (ATTAS lateral 6.8 to 11.2 ms over ten processes): glibc returned
each fit's freed work arrays to the system, and the next fit took them back
as fresh pages, 600 or 1,850 page faults a fit (getrusage) depending on
the heap's state, 1.6-4 ms of system time.  With the thresholds raised no
fit takes a fresh page once the heap has grown (tests/test_heap.py).  The
native build beside this one (five processes each, alternating, least CPU
of 100 fits): ATTAS lateral 6.49 against 6.50 ms, HFB-320 4.92 against
5.11 ms, C-8 0.45 against 0.47 ms.  Every case deck bitwise
(compare_cases: 40 of 40).

Measured (ours, branch sparse-forcing against main at 85893d4, one
thread): the model says which rows of df/dp and dh/dp can be nonzero
(model_t%param_rows; the longitudinal model from brow and COEF_OUTPUTS,
every other kind dense by default), asked once per integration.
  HFB-320    70.4 M -> 68.0 M instructions per fit (16.7 k -> 16.2 k per
             sample and iteration), 2389 -> 2421 allocations (four a
             likelihood evaluation: the rows' arrays): the RK4 forcing adds
             the one entry of each df/dp column instead of four (deriv
             8.20 -> 6.03 M, its scalar loop 27 -> 14 instructions a
             parameter); the outputs' C S + dh/dp adds d's last three rows
             alone (product_7x4_add_tail 4.04 -> 3.70 M).  Least CPU of 100
             fits (/tmp script, the builds' processes alternating, two runs
             of 5 rounds): main 4.91-5.06 ms, ours 4.77-5.11 ms, medians
             5.00 -> 4.86 and 4.97 -> 4.84 ms (8 of 10 pairs ours faster,
             about 0.12 ms).
  C-8, ATTAS lateral: unchanged (linear models, dense; C-8's +10 k a fit is
             in malloc's internals, the same calls).
Tried and dropped: dh/dp's one or two rows added entry by entry (each
column of C S in registers cannot take a row known at run time: more
instructions than the seven rows), the rows re-derived in rk4_step when
the parameters change (compared at every step: some 140 instructions a
step as first written, most of them the malloc of an automatic array of
dh/dp's rows; the caller now tells rk_work_size once instead).  Every case deck bitwise (compare_cases: 40 of
40); hfb320's JSON the same with one and two threads and from mlid-batch.

Measured (ours, branch al-eval-lean against main at 85893d4, one thread;
the longitudinal model's point, fortran/models/mlid_aero_long.f90, alone):
  HFB-320    70.4 M -> 69.8 M instructions per fit (16.73 k -> 16.60 k per
             sample and iteration), al_eval 14.74 -> 14.20 M self (19,208
             points a fit: 14,400 stages asking f, df/dx, df/dp, 4,808
             samples asking h, dh/dx, dh/dp too); a stage's point 670 ->
             640 instructions, a sample's 1,059 -> 1,036 (callgrind, a
             driver of the model alone, sincos not counted); 2389 -> 2384
             allocations; least CPU time 5.06 -> 4.72 ms (t.py, 5 rounds
             alternating with main, median ratio 0.941; again with 7
             rounds, the machine busier: 5.02 -> 4.86 ms, 0.969;
             bench_stage_eval --rounds 3: 5.28 -> 4.93 ms).
Most of the time came without instructions: main summed each coefficient
through memory (cx(at_value(k)) loaded, added to, stored, for the next term
to load again): a chain of store forwarding, on whose store 22 % of
al_eval's perf samples sat.  Each coefficient's value now sums in a
register, coefficient by coefficient (first step: 14.74 -> 14.80 M, least
CPU 4.97 -> 4.85 ms, median ratio of 7 rounds 0.961).  Then: df/dp's loop
with the tables and idx at explicit shapes (13 -> 11 instructions a
column), qdot's gradient once at a sample, the coefficients laid out
coefficient first and dh/dp's a_x and a_z factors in two arrays, so that
every entry is read by a single load from the single store that wrote it
(14.80 -> 14.20 M; ratio 0.991 against the first step).  Tried and
dropped: df/dp's (and dh/dp's) columns written in the coefficients' pass
when idx turns out to be 1..np (checked without a branch): 14.80 -> 13.88
M instructions but the fit 2.5-3 % slower (three runs of 5-7 rounds, both
orders), with b alone 14.12 M and 4 % slower, d alone 14.25 M and 1.3 %
slower; perf put the time in product_4x4, rk4_interval and integrate:
written there, b's columns come before a, so that a's sixteen 8-byte
stores are the last before deriv's product_4x4 loads a's columns 16 bytes
at a time (a load spanning two stores waits until they reach the cache),
and gfortran splits a column's zero pairs into 8-byte stores, which
add_forcing_4's 16-byte loads cannot take either.  Also dropped: the
sums in four lanes (value and the three gradients in registers, zeros
added where a regressor has none: 16.8 M, gfortran half-vectorises),
outputs' dh/dp loop with explicit-shape tables (+0.02 M), the quotients
of f and df/dx formed before the coefficients (+0.44 M, no faster), the
sincos calls in a routine of their own (gfortran 12 has no noinline).
Not done: eval's interface with explicit-shape p, u and idx (the
descriptors cost about 30 instructions a point, 0.6 M a fit: under 1 %,
for a change to every model kind).  Left: a is written with 8-byte
stores, and each column of b, c and d has an 8-byte store over its pairs
of zeros, while mlid_rk's kernels read them 16 bytes at a time (a store
of each pair would let those loads forward; gfortran does not build the
pairs from these expressions), the parameters' loops (about 12
instructions a term for the coefficients, 11 a column for df/dp), the
divisions (nine a stage, each kept as formed).  Every case deck's results
are unchanged to the bit (benchmarks/compare_cases.py: 40 of 40 bitwise;
HFB-320's JSON the same with one and two threads).
Measured (ours, one thread) after merging sparse-forcing and al-eval-lean,
one add_forcing for both (the rows a model names, any row else) and the
longitudinal model's sine and cosine from mlid_trig, against main at
85893d4 (--case all --rounds 5): HFB-320 70.4 -> 65.8 M instructions per
fit (16.7 k -> 15.6 k per sample and iteration), least CPU time 5.13 ->
4.61 ms, wall medians 5.41 -> 4.76 ms; C-8 and ATTAS lateral unchanged
(5.3 M and 85.6 M; their models are linear).  sin_cos alone (least CPU
of 300 fits, six and five rounds each taking turns with main's process):
4.71-4.88 ms before it against main's 4.90-4.97, 4.41-4.48 ms with it
against main's 4.86-4.96 (glibc's sincos had taken 9.7 % of the
fit's time, its own 5.8 %); a first version by Horner's rule gained a
third of that: its chain of dependent multiply-adds is what the model's
next stage waits on.  It moves hfb320.nml's output-error cases by rounding
(1.4e-12 sigma) and its filter-error cases 3 and 4 within tolerance
(7e-5 sigma); every other deck bitwise.

Measured (ours, one thread) at the stop that made the equations model's
sweeps lean (fortran/models/mlid_expr_diff.f90: the forward sweep from a tape of
plain arrays, its leaves first; every expression's reverse sweep in one
routine with adjoints local to the expression and the partials read from
one gradient cleared entry by entry; each folded model's lists allocated
once) and gave the seven-state product a kernel (mlid_rk's product_7x7),
against main at ee071e3 (--case tc22|tc32|tc33 --baseline, --rounds 5):
  tc22   888.8 -> 662.5 M instructions per fit, 15,467 -> 15,046
         allocations, least CPU time 67.4 -> 50.9 ms, wall 69.6 -> 52.9 ms;
  tc32   1,091.7 -> 816.2 M, 31,407 -> 28,297 allocations, 88.8 -> 67.0 ms
         CPU, 92.5 -> 70.0 ms wall;
  tc33   2,015.1 -> 1,296.8 M, 16,388 -> 15,967 allocations, 138.7 ->
         99.2 ms CPU, 142.7 -> 102.4 ms wall.
tc32's profile before (callgrind, 1,092 M): the forward sweep 288 M (39
instructions a node: its dispatch read the graph through descriptors),
the reverse sweeps 303 M with 21 M of memset, their caller 103 M, the
products 137 M (product_columns at four instructions a multiply-add for
7 x 7).  Tried and dropped: the partials gathered per expression through a
variable-to-adjoint map (+20 M: the gather's two-level indexing), the
reverse lists as one array of records (+4 M), the sweep loop in a helper
at explicit shapes (-8 M, 1 %, for a routine of nineteen arguments), two
columns a pass in product_7x7 (-7 M).  Then the shared reverse sweep (one
sweep, an adjoint per expression, which program_of's cost rule chose where
the expressions share most of their nodes) removed: with the lean
per-expression sweeps it lost on every model that took it, test case 27
593 -> 364 M and the six-degree-of-freedom fit of
cases/attas_lateral/sixdof_vs_linear.py 974 -> 695 M instructions (callgrind,
one fit each); the flight-path decks never took it.  Every case deck's
results are unchanged to the bit (compare_cases: 40 of 40 bitwise).
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = REPO.parent / "shared" / "data" / "hfb320_1_10.asc"
#: the fits measured: deck, the case fitted, the case that makes its record (or None)
CASES = {
    "hfb320": (REPO / "cases" / "hfb320" / "hfb320.nml", 0, None),
    "c8": (REPO / "cases" / "c8_short_period" / "c8.nml", 1, 0),
    "attas_lat": (REPO / "cases" / "attas_lateral" / "attas_lat.nml", 0, None),
    **{tc: (REPO / "cases" / "flight_path" / f"{tc}.nml", 0, None)
       for tc in ("tc22", "tc32", "tc33")},
}
ENTRY = "__mlid_api_MOD_mlid_fit"       # the core's fit: what callgrind counts
F2PY_ENTRY = "f2py_rout__core_mlid_api_mlid_fit"     # f2py's routine around it
ALLOCATORS = ("malloc", "calloc", "realloc")


def child(name, nfits, timed):
    """In a child process: nfits fits of case name; with timed, after a
    warm-up fit, the median wall time (timing.interleaved_medians), the
    least CPU time of one and the least time of the Python around the core
    call (mlid.fit's wall time less its result's wall_time, the core call
    alone).  Prints 'iterations nt wall_s cpu_s wrapper_s'."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    import time
    import mlid
    from mlid.cli.deck import run_case
    from timing import interleaved_medians
    deck, index, make = CASES[name]
    cases = mlid.read_deck(deck)
    if make is not None:
        run_case(cases[make])
    case = cases[index]
    data = case.record()
    opts = case.options()
    fit = lambda: mlid.fit(case.model, data, **opts)       # noqa: E731
    res = fit()
    wall = cpu = wrapper = 0.0
    if timed:
        (wall,) = interleaved_medians([fit], 1, nfits)
        cpus, wrappers = [], []
        for _ in range(nfits):
            c0 = time.process_time()
            fit()
            cpus.append(time.process_time() - c0)
        kept = []                     # freeing the last result is not the fit's
        for _ in range(nfits):
            w0 = time.perf_counter()
            kept.append(fit())
            wrappers.append(time.perf_counter() - w0 - kept[-1].wall_time)
        cpu, wrapper = min(cpus), min(wrappers)
    else:
        for _ in range(nfits - 1):
            res = fit()
    nt = sum(d.nt for d in data) if isinstance(data, list) else data.nt   # (manoeuvres)
    print(res.iterations, nt, wall, cpu, wrapper)


def run_child(name, pkg, nfits, timed, prefix=()):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if pkg:
        env["PYTHONPATH"] = str(pkg)
    out = subprocess.run([*prefix, sys.executable, __file__, "--case", name, "--child", str(nfits),
                          *(["--timed"] if timed else [])],
                         env=env, capture_output=True, text=True, check=True, cwd="/")
    iters, nt, wall, cpu, wrapper = out.stdout.split()[-5:]
    return int(iters), int(nt), float(wall), float(cpu), float(wrapper), out.stderr


def allocator_calls(path):
    """Calls of malloc, calloc and realloc in a callgrind output file (names
    are given once, at a function's first mention as fn= or cfn=)."""
    names, total, pending = {}, 0, False
    for line in Path(path).read_text(errors="replace").splitlines():
        m = re.match(r"c?fn=\((\d+)\)(?: (.*))?", line)
        if m:
            if m.group(2):
                names[m.group(1)] = m.group(2).strip()
            pending = line.startswith("cfn=") and names.get(m.group(1), "") in ALLOCATORS
        elif line.startswith("calls=") and pending:
            total += int(line.split("=")[1].split()[0])
            pending = False
    return total


def callgrind(name, pkg, nfits, entry=ENTRY):
    """Instructions and allocator calls per fit inside entry (all of the
    process's, entry None), the iterations and samples."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cg.out"
        toggle = [f"--toggle-collect={entry}"] if entry else []
        iters, nt, _, _, _, err = run_child(name, pkg, nfits, False, (
            "valgrind", "--tool=callgrind", *toggle,
            f"--callgrind-out-file={out}", "--compress-strings=yes"))
        ir = int(re.search(r"Collected : (\d+)", err).group(1))
        return ir / nfits, allocator_calls(out) / nfits, iters, nt


def wrapper_instructions(name, pkg, nfits):
    """Instructions per fit of the Python around the core call (the whole
    process's with 2 + nfits fits less with 2, per fit, less the f2py
    routine's), and of f2py's argument handling (its routine's less
    mlid_fit's).  PYTHONHASHSEED fixed: the runs differ by the fits alone."""
    os.environ["PYTHONHASHSEED"] = "0"
    few, many = (callgrind(name, pkg, n, None)[0] * n for n in (2, 2 + nfits))
    f2py = callgrind(name, pkg, nfits, F2PY_ENTRY)[0]
    return (many - few) / nfits - f2py, f2py - callgrind(name, pkg, nfits)[0]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--baseline", type=Path, help="folder holding another build's mlid package")
    ap.add_argument("--fits", type=int, default=3, help="fits per callgrind run")
    ap.add_argument("--rounds", type=int, default=5, help="timed rounds (20 + 20 fits each)")
    ap.add_argument("--case", choices=[*CASES, "all"], default="hfb320",
                    help="the fit measured: HFB-320 (default), C-8 short period, ATTAS lateral, "
                         "flight path tc22, tc32, tc33")
    ap.add_argument("--wrapper", action="store_true",
                    help="also the instructions of the Python and f2py around the core call")
    ap.add_argument("--child", type=int)
    ap.add_argument("--timed", action="store_true")
    a = ap.parse_args()
    if a.child is not None:
        return child(a.case, a.child, a.timed)
    if not DATA.is_file():
        print(f"skipped: real flight data not found at {DATA}")
        return
    for name in (CASES if a.case == "all" else [a.case]):
        measure(name, a)


def measure(case, a):
    """Instruction counts and times of one case's fit in each build."""
    builds = [("this build", None)] + ([("baseline", a.baseline.resolve())] if a.baseline else [])
    print(f"{case}:")
    if shutil.which("valgrind"):
        for name, pkg in builds:
            ir, allocs, iters, nt = callgrind(case, pkg, a.fits)
            print(f"  {name}: {ir / 1e6:.1f} M instructions per fit ({iters} iterations, {nt} "
                  f"samples: {ir / (iters * nt):.0f} per sample and iteration), "
                  f"{allocs:.0f} allocations per fit")
            if a.wrapper:
                python, f2py = wrapper_instructions(case, pkg, a.fits)
                print(f"  {name}: around the core call {python / 1e6:.2f} M instructions per "
                      f"fit of Python, {f2py / 1e3:.0f} k of f2py's argument handling")
    else:
        print("  valgrind not found: no instruction counts")
    walls = {name: [] for name, _ in builds}
    cpus = {name: [] for name, _ in builds}
    wrappers = {name: [] for name, _ in builds}
    for _ in range(a.rounds):
        for name, pkg in builds:
            _, _, wall, cpu, wrapper, _ = run_child(case, pkg, 20, True)
            walls[name].append(wall)
            cpus[name].append(cpu)
            wrappers[name].append(wrapper)
    for name, _ in builds:
        w = sorted(walls[name])[len(walls[name]) // 2]
        print(f"  {name}: {1e3 * w:.2f} ms wall (median of {a.rounds} processes' medians of 20), "
              f"{1e3 * min(cpus[name]):.2f} ms CPU (least of {a.rounds} x 20) per fit "
              f"in-process, one thread; {1e3 * min(wrappers[name]):.3f} ms of it around the "
              f"core call (least of {a.rounds} x 20)")


if __name__ == "__main__":
    main()
