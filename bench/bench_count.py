#!/usr/bin/env python3
"""Count benchmark: dense regular arrays and close clusters, located without and with the
flux.

Scenes from the project's generator (:mod:`invrad_wb.core.synthetic.generate`): regular
arrays of 9-20 downlights at spacings of 0.8-1.2 x the mounting height, clusters at 0.3 x,
mixed fluxes in one room; reflectances 0.7 / 0.5 / 0.2 with interreflection in the
targets, then 5 % multiplicative noise per vertex (seeded). Per scene and mode (flux
unknown, flux given): count right?, worst position error (cm), worst flux error (%),
seconds.

Usage: python bench/bench_count.py [--only NAME,...] [--noise 0.05] [--no-flux-given]
                                   [--given-only] [--cell 0.2] [--scene-cells NAME=M,...]
       python bench/bench_count.py --random N [--seed S] [--kinds 1|2]   (unseen rooms)
       python bench/bench_count.py --bound-only    (the bounds alone, seconds)

'sd cm' / 'sd %': the Cramer-Rao bound of the true arrangement on every target vertex
(:func:`bound`): the standard deviation of the worst-pinned luminaire's position (along
its worst direction) and flux that no unbiased estimate from these noisy data beats.

Measured 2026-11-25 on the shared 2-core machine (load 5-9, so seconds are wall seconds
of a busy machine; 'ok' = the count right and every luminaire matched within 0.5 m):

  before the count search (flux unknown): count right 0/7
    array12_issue 15/12, array9 11/9, array16 20/16, array20 11/20, array12_mixed 6/12,
    cluster4 1/4 (303 % flux), cluster3_mixed 1/3
  after (locate_count, points at their corners with free fluxes): count right in the 6
    scenes run (array20 not run again)
    array12_issue 12/12 35 cm 12 %, array9 9/9 6.2 cm 4.9 %, array16 16/16 (one beyond
    0.5 m) 22 cm 56 %, array12_mixed 12/12 47 cm 10 %, cluster4 4/4 41 cm 46 %,
    cluster3_mixed 3/3 47 cm 185 %
  flux given (unchanged code path): array12 3.5 cm, array9 4.8 cm, array16 15/16 31 cm,
    array20 19/20 39 cm, cluster4 33 cm
With 5 % noise per vertex, the positions and fluxes of close luminaires are not pinned by
the data: for cluster4 the found arrangement fits the noisy targets better than the true
one does (mean square log residual 0.001172 against 0.001196).

2026-11-26, after the last refit on every target vertex (_RoomFit.polish), load 6-9
(count / max cm / max flux % / wall s / CPU s / bound sd cm / bound sd %):
  free   array12_issue 12/12 yes 28.2 10.6 149 56 | 5.81 3.78
  given  array12_issue 12/12 yes  4.1       31 16 | 4.14
  free   array9_1.0h    9/9  yes  9.0  5.6  141 48 | 3.84 2.11
  given  array9_1.0h    9/9  yes  3.5       37 11 | 2.61
  free   array16_0.8h  16/16 NO  37.4 32.8  245 93 | 12.28 7.05  (count right, one > 0.5 m)
  given  array16_0.8h  15/16 NO  39.1       77 36 | 8.80
  free   array20_1.2h  20/20 yes  7.7  4.95 142 74 | 3.90 1.94
  given  array20_1.2h  19/20 NO  40.1       74 37 | 3.01
  free   array12_mixed 12/12 yes 43.6 20.8   90 44 | 9.65 6.13
  free   cluster4_0.3h  4/4  NO  42.5 76.7   50 25 | 8.60 9.77  (count right, one > 0.5 m)
  given  cluster4_0.3h  4/4  yes 29.9        7  4 | 8.41
  free   cluster3_mixed 3/3  NO  43.6 169    27 13 | 6.94 5.71  (count right, one > 0.5 m)
The count without the flux is right in all 7 scenes (array20 for the first time); the
errors are those of the noise, not bias nor local minima: refitted from the TRUE
arrangement on the same noisy targets, the luminaires move as far (array12_issue max
31.5 cm, array16 41 cm, cluster4 38 cm on the voting points), the mean displacement over
6 noise draws is within its standard error, and the bound (sd, one standard deviation,
a local bound: the clusters' likelihood is far from quadratic at this noise, their refits
from the truth scatter 19-21 cm RMS) is 2.6-12.3 cm. 2 cm for the worst of a dozen
luminaires needs about 2.5 sd <= 2 cm: noise of 0.8-2.6 % (flux given) and 0.3-1 % (free)
on this 0.2 m mesh (the bound scales with the noise and 1/sqrt(vertices)).
With the flux given, array16 and array20 miss one luminaire: greedy selection's absolute
floor (a luminaire must lower the cost by 0.5 % of the cost without any, 0.002 here)
rejects the missing one although it lowers the cost by 30 % (0.00160 -> 0.00112, about
1000 noise variances); with that floor at 0.0005, array20 comes out 20/20, 8.8 cm and
array16 16/16, 18.2 cm (not changed here: it moves every flux-given run).

2026-11-26, greedy selection judged against the noise (select.greedy_select: min_gain of
the current cost, both costs held at least the model floor, no floor of the empty room's
cost), --given-only, load 7-8 (count / max cm / wall s / CPU s / bound sd cm):
  given  array12_issue 12/12 yes  4.11  42 16 | 4.14   (before 12/12  4.1)
  given  array9_1.0h    9/9  yes  3.45  30 11 | 2.61   (before  9/9   3.5)
  given  array16_0.8h  16/16 yes 18.22  77 31 | 8.80   (before 15/16 39.1)
  given  array20_1.2h  20/20 yes  8.75  99 39 | 3.01   (before 19/20 40.1)
  given  cluster4_0.3h  4/4  yes 29.86  12  6 | 8.41   (before  4/4  29.9)

Against the Cramer-Rao bound ('rms/sd': root mean square position error over the true
luminaires / root mean square of their bound sd; an efficient estimate gives 1 to 1.41,
the error being 2-D and the sd along the worst direction), flux given, 5 % noise, 0.2 m:
  array12_issue rms 1.85 cm / sd 2.07 cm = 0.89;  array9_1.0h 1.75 / 1.32 = 1.33;
  array16_0.8h 6.39 / 4.55 = 1.40;  array20_1.2h 3.41 / 1.86 = 1.83
Locate reaches the bound on three of the four (array20 is 1.3 x beyond it). The bound
scales with the mesh spacing (one target per vertex, sd ~ 1 / sqrt(vertices)), as long as
every vertex is used (vertex_points takes at most 20000):
  --bound-only, flux given / free (cm): array9 0.2 m (7176 vertices) 2.61 / 3.84,
  0.15 m (12566) 1.95 / 2.89, 0.1 m (27846, 20000 used) 1.55 / 2.29; array16 0.2 m
  (7938) 8.80 / 12.28, 0.15 m (13910) 6.61 / 9.22, 0.1 m (30846, 20000 used) 5.50 / 7.72
2026-11-26 (h7), flux unknown, the whole suite on the final code (greedy selection with
free fluxes judged against the noise as with the flux given: FREE_FLUX_MIN_GAIN_TOTAL no
longer applies but with --aim free; watertight shadow rays), load 10-15
(count / ok / max cm / max flux % / wall s / CPU s / sd cm / sd % / rms/sd):
  array12_issue 12/12 yes 20.13  8.07 222 53 |  5.81 3.78 2.57  (before 28.2 cm 10.6 %)
  array9_1.0h    9/9  yes  8.89  5.51 168 35 |  3.84 2.11 2.12  (before  9.0      5.6)
  array16_0.8h  16/16 NO  10.76 31.79 232 86 | 12.28 7.05 5.22  (before 37.4     32.8)
  array20_1.2h  20/20 yes  7.71  4.95 112 74 |  3.90 1.94 1.50  (before  7.7      4.95)
  array12_mixed 12/12 yes 43.60 20.75  86 54 |  9.65 6.13 4.24  (before 43.6     20.8)
  cluster4_0.3h  4/4  NO  42.49 76.74  47 24 |  8.60 9.77 4.13  (before 42.5     76.7)
  cluster3_mixed 3/3  NO  43.58 168.6  22 11 |  6.94 5.71 7.79  (before 43.6     169)
  the count right in 7/7 (ok: also each within 0.5 m of a true one, 4/7); worst 43.6 cm,
  worst flux 168.6 %; 890 s. 'before' is the run recorded above (older code: before the
  noise-aware selection and the count criterion's clip), so the gain in array12_issue is
  not this change's alone; nothing got worse.
2026-11-26 (h7), 2 cm at 5 % noise, flux given: the last refit (polish) on every target
vertex (--points-max 10000000; the votes keep their sample) of a finer mesh. Bounds on
every vertex at 0.1 m (--bound-only): array16_0.8h 30846 vertices, worst sd 4.41 cm given
/ 6.20 cm free; array20_1.2h 50686 vertices, 1.51 / 1.96 cm. Located (load 4-6):
  array20_1.2h 0.2 m, 7.9 k vertices:       20/20, max 8.75 cm, rms/sd 1.83,  99 s / 39 CPU s
  array20_1.2h 0.1 m, 20000 of them (cap):  20/20, max 3.62 cm, rms/sd 1.18,  47 s / 26 CPU s
  array20_1.2h 0.1 m, all 50686:            20/20, max 2.69 cm, rms/sd 1.54,  65 s / 32 CPU s
  array20_1.2h 0.07 m, all (about 103 k):    20/20, max 2.81 cm, rms/sd 1.91,  82 s / 44 CPU s
  (sd 1.05 cm; the 0.2 m row was recorded at load 7-8; each mesh draws its own noise)
  array20_1.2h 0.05 m (about 200 k vertices): stopped unfinished after 10 min wall
With the worst error about 2.5 sd, under 2 cm needs sd <= 0.8 cm: array20 about 0.053 m
(180 k vertices) given, 0.041 m free; array16 about 0.018 m (950 k vertices) given, 0.013
m free. Not reached at 0.1 m; the bound, not locate, is what stops it.
A worst-luminaire sd of 2 cm at 5 % noise needs about 0.2 x 2 / sd(0.2 m) metres: 0.15 m
for array9, 0.045 m for array16 (flux given, about 160000 vertices; 0.033 m free, about
290000: far beyond vertex_points' 20000); the worst of a dozen luminaires within 2 cm (about 2.5 sd) needs
0.06 m for array9 and 0.018 m for array16. Run at 0.15 m, array9 (flux given): 9/9, max
2.33 cm, rms/sd 1.20, bound 1.95 cm (at 0.2 m: max 3.45 cm), 7.9 CPU s.

2026-11-26 (h9), the bound beside the errors, and the search's faults apart from the data's
limit (--diagnose: per luminaire its error, its Cramer-Rao sd and the error of the truth's
own refit on the same noisy data; per scene 'gap chi2', the found answer's cost above the
truth's refit in noise variances: beyond a few, a better minimum near the truth that the
search missed; about 0 or below, the found answer fits as well, and its error is what the
data allow). Flux unknown, 5 % noise, 0.2 m mesh, every vertex in the last refit, runs
alternated base (930e8fa) / after (locate_count.regroup at the last refit), load 4-6
(count / ok / max cm / max flux % / wall s / CPU s / sd cm / sd % / rms/sd / gap chi2):
  cluster3_mixed base  3/3  NO  43.58 168.61  17  10 | 6.94 5.71 7.79  5.0
                 after 3/3  yes 16.07  42.28  21  13 | 6.94 5.71 2.52  1.6
  cluster4_0.3h  base  4/4  NO  42.49  76.74  37  16 | 8.60 9.77 4.13 15.1
                 after 4/4  yes 41.77  63.83  42  20 | 8.60 9.77 4.10  0.8
  array12_mixed  base 12/12 yes 43.60  20.75  81  35 | 9.65 6.13 4.24  2.5
                 after  (the same answer)     89  38
  array16_0.8h   base 16/16 NO  10.74* 31.89 141  59 |12.28 7.05 5.21 39.5
                 (* of those matched within 0.5 m; two more 81.7 and 62.2 cm off)
                 after 16/16 yes 37.54 10.88 167  79 |12.28 7.05 2.46  2.3
  array9_1.0h    base  9/9  yes  8.89   5.51  59  29 | 3.84 2.11 2.12  3.2
                 after  (the same answer)     58  30
  array12_issue  base 12/12 yes 20.14   8.07  85  42 | 5.81 3.78 2.57  2.3
                 after 12/12 yes 15.59  6.39  98  52 | 5.81 3.78 1.89 -0.3
  array20_1.2h   base 20/20 yes  7.71   4.95  93  54 | 3.90 1.94 1.50  1.2
                 after  (the same answer)    144  73
  before: count right 7/7, each within 0.5 m 4/7, worst flux 168.6 %; search faults (gap
  over 5) in cluster4 (15), array16 (40: its inner four, 51-82 cm off with sd 12 cm,
  where the truth's refit is 2-25 cm off) and cluster3_mixed (5).
  after: count right 7/7, each within 0.5 m 7/7, worst 43.6 cm, worst flux 63.8 %; every
  gap at most 2.5 noise variances: what is left is the data's limit at this mesh. It is
  beyond the (local) bound where close luminaires trade flux against position: the
  truth's own refit is 24-36 cm and 4-30 % off in cluster4 (sd 8.6 cm, 9.8 %), 36 cm in
  array12_mixed's 2000 lm luminaire (sd 9.7 cm), and regroup's starts find arrangements
  that fit the noisy data better than the truth's refit does (cluster3_mixed: cost
  0.0010742 against 0.0010756, 42 cm and 239 % off): several arrangements explain these
  data equally well. The CPU cost of regroup: 0-20 s a room with groups; array9, array20
  and array12_mixed have none (close_groups on their true arrangements: [], 0.01-0.07 CPU
  s), so array20's 54 -> 73 CPU s is the busy machine's (OpenCL threads), not regroup.
  The clusters at a 0.1 m mesh (every vertex, --points-max 10000000; base / after,
  alternated, max cm / max flux % / CPU s / sd cm / sd % / gap chi2):
    cluster4_0.3h  base 11.80 36.14 13 | 4.31 4.88  2.2   after 7.74 19.29 25 | 0.5
    cluster3_mixed base 16.41 40.98  6 | 3.48 2.90 13.5   after 7.54 18.06 22 | 3.1
  the errors halve with the bound; the flux errors (4-6 sd) are still beyond it where
  flux trades against position (cluster3_mixed's 4000 lm luminaire: 7.5 cm, sd 1.3 cm,
  its truth's refit 1.5 cm, gap 3.1: in this flat valley each restart of the optimiser
  still lowers the cost a little; offline on array16, three regroup passes went 0.0010571
  -> 0.0010560 -> 0.0010558 against the truth's 0.0010554).
Flux given (--given-only --diagnose, after; the flux-given path is unchanged): array16
18.23 cm (sd 8.80, gap -0.3), array20 8.75 cm (sd 3.01, gap -0.3), cluster4 29.86 cm (sd
8.41, gap 0.1): the same answers as before, each the data's limit (no gap).
The bound (--bound-only --cells 0.2,0.1 --points-max 10000000), worst luminaire, flux
free sd cm / sd % (flux given sd cm), 0.2 m -> 0.1 m (it halves with the spacing):
  array12_issue  5.81/3.78 (4.14) -> 2.92/1.90 (2.07)
  array9_1.0h    3.84/2.11 (2.61) -> 1.93/1.06 (1.30)
  array16_0.8h  12.28/7.05 (8.80) -> 6.20/3.54 (4.41)
  array20_1.2h   3.90/1.94 (3.01) -> 1.96/0.97 (1.51)
  array12_mixed  9.65/6.13 (6.54) -> 4.88/3.10 (3.29)
  cluster4_0.3h  8.60/9.77 (8.41) -> 4.31/4.88 (4.21)
  cluster3_mixed 6.94/5.71 (6.68) -> 3.48/2.90 (3.35)
The Done-when (flux unknown: every luminaire within 2 cm and 5 %, about 2.5 sd for the
worst of a dozen: sd <= 0.8 cm and 2 %) needs a mesh of 0.041 m (array9, array20), 0.027
m (array12_issue), 0.023 m (cluster3_mixed), 0.019 m (cluster4), 0.016 m (array12_mixed),
0.013 m (array16): 165 000 to 1 800 000 target vertices per room; with the flux given
(2 cm) 0.062 m (array9) down to 0.018 m (array16). Not run: vertex_points keeps at most
20000 and a locate at 0.05 m did not finish in 10 minutes on this machine.

2026-11-26 (h10), every target vertex of a finely meshed room: locate's last refit is
streamed over all of them (locate_vertices.VertexProblem, after regroup on the 20 000-vertex
subset: LM normal equations summed per 50 000-vertex chunk, direct light exact, each
luminaire's interreflection gathered exactly once at every vertex, its change as it moves
interpolated from the subset; the truth render's gather in row chunks, GATHER_MAX_MB).
Flux unknown, 5 % noise, load 4-5 ('rss': the whole process's peak, truth render and
bound included; count / ok / max cm / max flux % / wall s / CPU s / rss MB / sd cm / sd % /
rms/sd):
  array9_1.0h   0.10 m   27846 v  9/9  yes  1.24 1.29   62  37      |  1.93 1.06 1.15
  array9_1.0h   0.04 m  170856 v  9/9  yes  1.40 0.82  139  53  881 |  0.78 0.43 2.19
  array20_1.2h  0.04 m  313008 v 20/20 yes  2.60 0.61  253 129  986 |  0.78 0.39 2.03
  array12_issue 0.027 m 409022 v 12/12 yes  9.72 3.60  235 142 1224 |  0.79 0.51 10.2
  (0.2 m, before: array9 8.9 cm 5.5 %, array20 7.7 cm 4.95 %, array12_issue 15.6 cm 6.4 %)
array9 meets 2 cm / 5 % (the Done-when), array20 is 2.6 cm (3.3 sd) with 0.6 %. array12_issue
is not the bound's: at 0.06 m (83274 vertices, --diagnose as a script) ten luminaires are
within 1 cm and the two inner ones of the middle row 9.5 and 7.9 cm off; the truth's own
refit on the same data leaves them 6.4 and 4.8 cm off (gap 2.3 noise variances: the found
answer is a neighbouring minimum of that valley, twelve more LM rounds from it move nothing),
noise-free the truth's refit stays within 0.01 cm (no model bias): the likelihood of those
two is far from quadratic, the local bound (about 1.7 cm there) says too little.
The clusters, same run conditions (count / ok / max cm / max flux % / wall s / CPU s / rss MB /
sd cm / sd % / rms/sd):
  cluster4_0.3h  0.019 m 353086 v  4/4  yes 11.32 29.04  132  95 1305 | 0.82 0.95 10.9
  cluster3_mixed 0.023 m 241740 v  3/3  yes 20.79 64.47   96  54 1399 | 0.80 0.68 36.2
  (0.2 m: cluster4 41.8 cm 63.8 %, cluster3_mixed 16.1 cm 42.3 %)
Not the bound's either: the streamed refit starts from the subset's answer (20 000
vertices, regroup's choice there) and ends in the minimum of its valley; the finer data do
not move it to the truth's. Tried and left out: regroup's starts (polygons, dictionary; on
the subset) each refitted on every vertex: array12_issue the same 9.72 cm for 272 instead of
142 CPU s, cluster4 13.1 cm 30.1 %. Noise-free, a refit of cluster4 (0.1 m, every vertex)
from 8-10 cm and 15 % off its luminaires ends 9-11 cm off too (cost 4.9e-6 against 3.9e-6
at the truth): the valley has minima of its own; finding the right one at this precision
needs a global step that this round has not got.
2026-11-26 (h11), why the fine meshes stayed 2-25 bound sd off, and the fix. Between two
refreshes the refit held each luminaire's interreflection where it was last computed:
(1) the refit then stopped where the direct light's gradient alone is zero, not at the
likelihood's minimum (the refresh loop's fixed point is off it), and noise-free it had
stationary points of its own (cluster4 at 0.1 m, every vertex, no noise, refitted from
9 cm and 15 % off: held, ends 2.4-8.8 cm and up to 24 % off, cost 3.98-4.07e-6; with the
gradient every start ends within 0.08 cm and 0.2 %, cost 3.92e-6); (2) the bound's Fisher
information lacked the interreflection's dependence on the positions (on the ceiling all
the light is interreflected: array12_issue at 0.2 m, the column norm of d indirect / d x is
0.75 of the direct light's 1.86), and was too narrow: 2.0x for array12_issue's inner pair,
2.2x / 5.7x (position / flux) for cluster4, 2.9x / 8.7x for cluster3_mixed. Now
(RefineProblem.indirect_gradient, set in locate's last refit and here): each luminaire's
interreflection follows its position to first order (its gradient, central differences
of the radiosity solve) in the model and the Jacobian, and the bound is the full model's.
Truth-started refits, 0.2 m, 5 % noise, 6 noise draws (worst luminaire per draw, mean;
held -> gradient): array12_issue 16.2 -> 12.1 cm, 7.96 -> 5.28 %; array9 6.51 -> 5.09 cm,
3.85 -> 2.64 %; cluster4 28.0 -> 25.3 cm, 43 -> 59 % (far beyond the quadratic regime).
The fine meshes (flux unknown, 5 % noise, every vertex; count / max cm / max flux % / wall
s / CPU s / rss MB / sd cm / sd % / rms/sd / gap chi2; sd the full model's bound, the
old one in brackets), load 4-6:
  array12_issue  0.027 m 409022 v 12/12  2.33 1.06 170 129 1203 | 1.57 0.72 1.25
                 (before 9.72 cm 3.60 %, 235 s; old bound 0.79 cm)
  cluster4_0.3h  0.019 m 353086 v  4/4   2.22 4.05 182 122 1261 | 1.82 5.41 0.87  0.7
                 (before 11.32 cm 29.04 %, 132 s; old bound 0.82 cm 0.95 %)
  cluster3_mixed 0.023 m 241740 v  3/3   1.51 4.08 112  59 1518 | 2.30 5.89 0.60  1.1
                 (before 20.79 cm 64.47 %, 96 s; old bound 0.80 cm 0.68 %)
  array20_1.2h   0.04 m  313008 v 20/20  1.65 0.61 217 166  982 | 0.93 0.44 1.17
                 (before 2.60 cm 0.61 %, 253 s; old bound 0.78 cm)
  flux given: cluster4 0.019 m 1.16 cm (sd 0.76), 92 s; array12_issue 0.027 m 0.52 cm
  (sd 0.54), 133 s / 97 CPU s
  array12_issue 0.06 m (--diagnose): 5.22 cm 2.05 % (before 9.5 cm), the inner pair 5.22
  and 4.38 cm with sd 3.43 / 3.47 cm, the truth's own refit 5.14 / 4.36 cm, gap 0.1
Every scene within 2.5 cm and 5 % of flux; each at most 1.5 sd of the full bound (the gap
to the truth's own refit about 1 noise variance: no search fault left). The Done-when's
2 cm for the worst luminaire needs that bound at about 0.8 cm: array12_issue about 0.014
m, cluster4 about 0.008 m (the flux's sd 5.4 % also wants it finer).
The 0.2 m bench (default arguments) after, load 4-6 (count / ok / max cm / max flux % /
wall s / CPU s / sd cm / sd % / rms/sd; the bound now the full model's; before: h9's
rows above for the flux unknown, h7's for the flux given):
  free   array12_issue 12/12 yes 22.26  7.23  89 41 | 11.70  5.34 1.55 (before 15.59  6.39)
  free   array9_1.0h    9/9  yes  2.99  1.81  51 26 |  5.16  2.26 0.77 (before  8.89  5.51)
  free   array16_0.8h  16/16 yes 25.48 15.91 156 78 | 17.40 10.73 1.11 (before 37.54 10.88)
  free   array20_1.2h  20/20 yes  9.61  4.76  87 59 |  4.64  2.19 1.37 (before  7.71  4.95)
  free   array12_mixed 12/12 yes 36.80 22.61 113 54 | 17.51  7.86 2.17 (before 43.60 20.75)
  free   cluster4_0.3h  4/4  yes 42.94 64.49  90 28 | 19.03 56.66 1.86 (before 41.77 63.83)
  free   cluster3_mixed 3/3  yes 35.02 178.5  33 15 | 19.97 51.01 1.90 (before 16.07 42.28)
  given  array12_issue 12/12 yes  3.79       23 11 |  4.02       0.90 (before  4.11)
  given  array9_1.0h    9/9  yes  4.20       12  6 |  2.44       1.51 (before  3.45)
  given  array16_0.8h  16/16 yes 18.02       21 16 |  8.55       1.43 (before 18.22)
  given  array20_1.2h  20/20 yes  8.42       38 22 |  2.90       1.85 (before  8.75)
  given  cluster4_0.3h  4/4  yes 28.53       11  3 |  8.01       3.48 (before 29.86)
  count right 7/7 and 5/5 (as before); one noise draw each, at 0.2 m the bound is 2-20 cm
  and 2-57 %, so single worst errors move by a bound sd either way: free worst 43.60 ->
  42.94 cm, flux 63.83 -> 178.5 % (cluster3_mixed, one draw; over draws
  1-3, the whole locate, before -> after: max 37.0 / 18.7 / 43.9 -> 26.6 / 12.8 / 42.1 cm,
  flux 71 / 52 / 191 -> 86 / 33 / 173 %, RMS 38.0 / 13.7 / 29.4 -> 18.6 / 10.6 / 28.1 cm,
  12-18 -> 21-26 s: the gradient's radiosity solves in regroup's refits); given worst 29.86 ->
  28.53 cm.
Memory at 1.78 million vertices (array16_0.8h's room at 0.013 m, a throwaway script): building the
scene (box_room, 3.55 million faces) 21 CPU s, 756 MB held, 2.1 GB peak (check_winding's
edge arrays, about 500 bytes a face, after this round's 287 -> 225 MB at 0.04 m). Then,
targets direct light only + 5 % noise (CPU s / RSS after): render 42 s / 1465 MB; the
vertices (vertex_points) 2.4 s / 1045 MB; the subset problem (20 000 vertices, its radiosity
model) and the VertexProblem (36 chunks, interpolation weights) 70 s / 2223 MB, peak 3252 MB;
the exact gather of 16 luminaires' interreflection at every vertex 646 s / 2452 MB (the
streamed refit's one expensive step: about 0.36 ms a vertex on this machine); one cost on
every vertex 4.5 CPU s (2.3 s wall); three LM steps 60 CPU s; the Fisher bound 12 CPU s.
The refit's own arrays stay bounded by the chunk; the resident memory is the scene's
(about 200 bytes a face), the vertices' (130 bytes each, held twice in that script) and
the radiosity model of a 3.55 million-face room.

Round 12 (h12-fine), 2026-11-26, finer meshes on this machine (23 GB, 2 shared cores, load
4-5; flux unknown, 5 % noise, every target vertex in the last refit with the
interreflection's gradient; count / ok / max cm / max flux % / locate wall s / CPU s / peak
rss MB / sd cm / sd % / rms/sd; sd the full model's bound):
  array12_issue  0.014 m 1509728 v 12/12 yes 0.86 0.38 562 401 4078 | 0.81 0.37 1.05
                 (0.027 m: 2.33 cm 1.06 %, sd 1.57 cm; the build, render with
                 interreflection, 10 min wall, peak 2893 MB)
  cluster4_0.3h  0.012 m  880174 v  4/4  yes 2.06 5.24 294   -  2578 | 1.15 3.42 1.44
                 (0.019 m: 2.22 cm 4.05 %, sd 1.82 cm 5.41 %; build 253 s wall; build,
                 locate and bound together 301 CPU s)
  cluster4_0.3h  0.008 m 1975756 v  4/4  yes 1.04 3.62 942   -  3397 | 0.77 2.28 1.20
                 (build 963 s wall; build, locate and bound 1229 CPU s; run on the code
                 before this round's patch-statistics change)
array12_issue and cluster4 meet the Done-when (2 cm, 5 %, flux unknown) at 0.014 m and
0.008 m, each at its bound (rms/sd 1.05, 1.20); at 0.012 m cluster4 was 1.8 sd (position)
and 1.5 sd (flux) of its bound off, just outside. Flux given not rerun finer (0.027 m
0.52 cm and 0.019 m 1.16 cm already within 2 cm). array16 and array12_mixed at 0.04 m
(load 2-4, with the patch change; same columns):
  array12_mixed  0.04 m  182768 v 12/12 yes 1.40 1.08  49  47 1064 | 3.51 1.58 0.52
  array16_0.8h   0.04 m  189426 v 16/16 yes 3.96 1.01 105 106 1597 | 3.48 2.15 0.95
  given array16  0.04 m  189426 v 16/16 yes 4.18       31  33 1597 | 1.72      1.82
array12_mixed is within 2 cm / 5 % already at 0.04 m (one draw, 0.4 sd); array16 is at its
bound (free) and needs about 0.013 m (free) / 0.02 m (given), not run (30-40 min wall here).
Memory: the peak RSS grows by about 2.7 kB per target vertex (0.027 m, 409 022 vertices:
1203 MB; 0.014 m, 1 509 728: 4176 MB by /usr/bin/time, truth render and bound included),
so 2 million vertices take about 5.5 GB: time, not memory, is this machine's limit (the
scene and its render 5-6 CPU min, locate 401 CPU s at 1.51 million vertices). The
largest transient of locate at 880 174 vertices (RSS sampled with the stack every 0.1 s)
was the radiosity model's patch statistics (patches._cluster_stats' (T, 3, 3) corner
distances, +1.17 GB over the baseline, the same in the truth render): now in blocks of
2^18 triangles, and each room's triangles copied once: the model's build peaks at 365
instead of 564 bytes a face (630 000 faces: 219 against 339 MB of numpy allocations),
the patches bit for bit the same. The streamed refit's own arrays (50 000-vertex chunks,
about 220 bytes a vertex by their sizes: views, a float64 interreflection and coordinate
rows per chunk, up to 64 one-byte visibility masks, the interpolation's 64 bytes, the
exact interreflection in float32) were not the peak and are left as they are. At 0.008 m
(3.94 million faces) the peak, 3.3 GB, is the scene's construction (its face areas'
cross products) and, in the bench's bound, its canvas (votemaps._dummy_maps'
raster.locate_points, +1.5 GB): neither is locate's.
The count search and selection (on the 20 000-vertex subset, interreflection held between
refreshes) do not need the gradient: the count is right in every scene at every mesh run
(7/7 at 0.2 m, and each fine mesh), and the last refit from their answer ends at the bound
(rms/sd 1.05 and 1.44 here, 0.6-1.25 at h11's meshes, the gap to the truth's own refit
0.1-1.1 noise variances): no error is left that starts there.

Round 13, 2026-11-26, flux given at 0.04 m (main df90e11; 2 cores at load 4-6 with other
sessions' jobs; 5 % noise, one draw each; count / ok / max cm / locate wall s / CPU s / rss
MB / sd cm / rms/sd):
  given array9_1.0h   0.04 m 170856 v   9/9  yes 0.51  30 15 1613 | 0.49 1.30
  given array20_1.2h  0.04 m 313008 v  20/20 yes 0.91 1236 672    - |    -    -
  (array20: read from the running process, whose bound was stopped after 50 min: the
  bound's interreflection gradient at every vertex, not locate's, is the slow step; before:
  0.1 m 2.69 cm, 0.07 m 2.81 cm)
With these, every scene but array16 meets the Done-when with the flux given (array12_issue
0.52 cm, cluster4 1.16 cm) and without it (the rows above). array16 without the flux at
0.013 m (1 781 920 vertices) was stopped after 110 min wall (58 CPU min at load 5-6, still
in locate's last refit: each interreflection refresh at every vertex is about 11 CPU min
here); with the flux at 0.02 m not run.

Round 14, 2026-11-27, array16 on the default path (the 20 000-vertex subset, then the
streamed refit on every vertex; round 13's --points-max 100000000 made the subset the whole
room: no streamed refit, no interreflection gradient, each refresh a gather at all 1.78
million vertices, hence its unfinished 110 min). 5 % noise, one draw each, 2 cores, the
other core busy (count / ok / max cm / max flux % / locate wall s / CPU s / rss MB):
  given array16_0.8h 0.016 m 1176758 v 16/16 yes 0.83        433  296 2961
  free  array16_0.8h 0.013 m 1781920 v 15/16 NO 32.38 34.52 1452 1461 3793  (before)
  free  array16_0.8h 0.013 m 1781920 v 16/16 yes 2.77  1.65 2381 2450        (after)
Bound at 0.016 m (--bound-only --cells 0.016): flux free 1.40 cm 0.86 %, given 0.69 cm
(the given row 1.2 sd); at 0.013 m about 1.14 cm free (by the spacing), so 2.77 cm is
about 2.4 sd, the worst of sixteen. 'before': the count search's criterion on the subset
turned the 16th luminaire's split down (at 0.07 m it had gained only 3.8 there); 'after':
that split judged again on every vertex (locate_fit._RoomFit.count_on_every_vertex), kept.
At 0.07 m (63 106 vertices, count right both ways) the check turned the 17th down by 29,
+55 CPU s. --diagnose on the 'after' run: gap chi2 0.2 (no search fault); twelve
luminaires within 0.26 cm, the inner four 1.40, 2.77, 1.81 and 1.02 cm off, the truth's
own refit on the same data 1.33, 2.64, 1.74 and 0.88 cm: the data's limit at this mesh.
With the flux given every scene is now within 2 cm; without it array16 is the one scene
beyond 2 cm (2.77 cm; count and flux within the Done-when): the truth's refit scales with
the spacing, so about 0.009 m (some 3.7 million vertices, about 10 GB by the rows above,
an hour or more of one core here) should bring it under 2 cm. Not run.

Round 15, 2026-11-27: the count check on every vertex gathers its split's interreflection in
the start's pass (VertexProblem.exact_indirect(lights, *more)); before, a pass of its own
(0.36 ms a vertex at 0.013 m: 646 of the check's 990 CPU s). array16_0.8h, flux free, the
same answer, the other core busy (locate wall s / CPU s):
  0.07 m  63106 v 16/16 11.07 cm 3.33 %  before 181.9 / 176.6  after 177.5 / 170.9
  0.03 m 335766 v 16/16  2.86 cm 2.35 %  before 452.0 / 443.4  after 417.2 / 383.7
  0.013 m 1781920 v 16/16 2.77 cm 1.65 %  before 2381 / 2450 (round 14)  after 1961 / 1945
array16_0.8h flux free at 0.009 m (the old code: two passes; alone on one core for its first
35 min, then beside CI runs and the rows above; count / ok / max cm / max flux % / locate
wall s / CPU s / peak RSS of the whole process, its diagnosis stopped unfinished):
  free  array16_0.8h 0.009 m 3712368 v 16/16 NO  2.19  0.76 4760 4840 7511 MB
Build and render (interreflection gathered at every vertex) about 34 min before it. From
0.013 m (2.77 cm) to 0.009 m the worst error fell by 0.79 for a spacing ratio of 0.69: still
about 2.8 times the bound's sd scaled by the spacing (about 0.79 cm), as 2.77 cm was 2.4.
The same room without noise (--noise 0 --cell 0.03 --diagnose): 16/16, worst 0.05 cm, flux
0.01 %, 129 s, the truth's own refit 0.01 cm at worst: the model holds no bias, the error is
the noise's (the likelihood of close luminaires with free fluxes, not quadratic that far out,
is wider than the bound).

Round 16 (h14-tie), 2026-11-27: luminaires of one kind. With the flux unknown each
luminaire had a flux of its own, and in arrays and clusters the fluxes trade against the
positions: array16's worst-luminaire bound at 0.2 m is 17.40 cm with free fluxes, 8.55 cm
with one shared flux, 8.55 cm with the flux given (the Fisher information with the fluxes'
columns summed; --bound-only's free and given columns). Now (core/inverse/locate_ties.py)
after the count is chosen the fitted fluxes the data cannot tell apart (the growth of
their Wald statistic below ln(points), the count criterion's price of a parameter) are
tied, refitted, and kept when that criterion is lower; on every vertex where the last
refit streams. 5 % noise, one draw each, flux unknown (count / ok / max cm / max flux %
/ locate wall s / CPU s), 0.2 m, before (main 7824e6a) and after, run one after the
other on the same machine, the other core busy:
  array12_issue  12/12 yes 15.59  6.39 22.7 21.9  ->  12/12 yes  4.16  0.10 22.5 22.8
  array9_1.0h     9/9  yes  8.89  5.51 12.0 12.2  ->   9/9  yes  3.40  0.08 11.4 11.7
  array16_0.8h   16/16 yes 33.82  9.58 37.3 37.4  ->  16/16 yes 17.87  0.10 43.4 41.5
  array20_1.2h   20/20 yes  7.71  4.95 28.2 30.1  ->  20/20 yes  8.85  3.25 29.9 29.5
  array12_mixed  12/12 yes 43.60 20.75 17.1 17.6  ->  12/12 yes 27.64  5.02 17.5 18.0
  cluster4_0.3h   4/4  yes 41.77 63.83 12.6 10.1  ->   4/4  yes 30.59  0.11  9.9 10.5
  cluster3_mixed  3/3  yes 16.07 42.28 12.4  6.5  ->   3/3  yes 22.22 77.57  5.6  6.2
cluster3_mixed's 1500 / 2500 / 4000 lm come out as one kind at 0.2 m: their fluxes' sd
there is 51 % (the bound), the data cannot tell them apart, and the criterion says so;
array20 keeps three groups (2902 / 2975 / 3044 lm: all twenty as one cost 1.9 more).
The fine meshes after (same columns; 'before': the rows of rounds 11-15 above):
  array16_0.8h   0.013 m 1781920 v 16/16 yes 0.83 0.08 2490 2162  (before 2.77 1.65;
                 0.009 m 2.19 0.76)
  array12_issue  0.03 m   330142 v 12/12 yes 0.91 0.08  205  203  (before 0.027 m 2.33
                 1.06, 0.014 m 0.86 0.38)
  array9_1.0h    0.04 m   170856 v  9/9  yes 0.58 0.08   65   67
  array20_1.2h   0.04 m   313008 v 20/20 yes 0.87 0.08 1084  759  (before 1.65 0.61)
  array12_mixed  0.04 m   182768 v 12/12 yes 1.62 0.20  206  152  (before 1.40 1.08)
  cluster3_mixed 0.023 m  241740 v  3/3  yes 1.50 4.08  208  138  (before 1.51 4.08:
                 its three kinds stay apart)
  cluster4_0.3h  0.015 m  564542 v  4/4  yes 0.86 0.08  154  171  (before 0.012 m 2.06
                 5.24, 0.008 m 1.04 3.62)
  array16_0.8h   0.04 m   189426 v 16/16 yes 4.17 0.08  380  382  (before 3.96 1.01; the
                 flux given 4.18: one shared flux pins them as the given flux does)
Every scene now meets the Done-when (count right, within 2 cm and 5 %), array16 at 0.013
m instead of beyond 0.009 m. The array20 row ran beside two other benches (its wall s);
most of its CPU s is the count check on every vertex, its 21-luminaire split refitted (at
0.08 m, locate 306 CPU s before, the check 234 of them; 339 after, the ties 12 of them).
Rooms never tuned on (--random 10: bench_random's generator, 1-6 ceiling, wall and pendant
luminaires, interreflection, 0.1 m mesh, 5 % noise; the same procedure run on main 7824e6a
as a script beside it; worst cm / worst flux % per room, before -> after):
  --seed 2027 (one flux per room): count right 10/10 both; 0.70/0.72 -> 0.81/0.11,
  0.61/0.46 -> 0.61/0.11, 1.72/2.44 -> 1.11/0.02, 1.18/1.15 -> 0.66/0.05, 1.87/0.29 ->
  1.79/0.03, 0.38/0.12 -> 0.41/0.05, 0.75/0.40 -> 0.74/0.07, 1.51/3.09 -> 0.86/0.15,
  1.24/0.61 -> 0.82/0.06, 0.19/0.09 both; CPU s 68.1 -> 68.8 in all
  --seed 2028 --kinds 2 (1 : 1.6): no two kinds tied; 9/10 right both; the three rooms
  that changed 2.54/2.75 -> 1.59/0.39, 0.33/0.74 -> 0.33/0.36, 1.59/2.41 -> 0.42/0.12,
  the rest the same. The tenth (6 luminaires in 6.3 x 3.1 m) is 5/6 both ways: with 5 %
  noise a wall light's 3541 lm goes to the ceiling luminaire 2 m in front of it (8818 lm
  found for 5665); noise-free all six are found.
"""
import argparse
import os
import resource
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

from invrad_wb.core.synthetic import generate as g  # noqa: E402
from invrad_wb.core.model.luminaires import Luminaire  # noqa: E402
from invrad_wb.core.forward.render import render  # noqa: E402
from invrad_wb.core.inverse.locate import locate  # noqa: E402
from invrad_wb.core.synthetic.scenarios import match  # noqa: E402


def _array(nx, ny, spacing, height, flux, margin=None):
    """A room just large enough for an nx x ny grid at ``spacing`` (half a spacing to the
    walls) with downlights on its ceiling; ``flux`` a number or a function (i, j) -> lm."""
    m = 0.5 * spacing if margin is None else margin
    w, d = 2 * m + (nx - 1) * spacing, 2 * m + (ny - 1) * spacing
    lums = []
    for i in range(nx):
        for j in range(ny):
            f = flux(i, j) if callable(flux) else flux
            lums.append(Luminaire([m + i * spacing, m + j * spacing, height], [0, 0, -1],
                                  float(f)))
    return (w, d, height), lums


def _cluster(room, centre, n, gap, flux, height):
    """n downlights on a circle whose neighbours are ``gap`` apart (n = 2: a pair)."""
    r = gap / (2 * np.sin(np.pi / n)) if n > 2 else gap / 2
    out = []
    for k in range(n):
        a = 2 * np.pi * k / n + 0.3
        f = flux[k] if np.ndim(flux) else flux
        out.append(Luminaire([centre[0] + r * np.cos(a), centre[1] + r * np.sin(a), height],
                             [0, 0, -1], float(f)))
    return room, out


def scenes():
    """name -> (room size (w, d, h), luminaires)."""
    mixed = [2000.0, 3500.0, 5000.0]
    return {
        # the case: twelve 4000 lm on a 2.5 x 3 m grid, 10 x 9 x 3 m
        "array12_issue": ((10.0, 9.0, 3.0), [Luminaire([1.25 + 2.5 * i, 1.5 + 3.0 * j, 3.0],
                                                       [0, 0, -1], 4000.0)
                                             for i in range(4) for j in range(3)]),
        "array9_1.0h": _array(3, 3, 3.0, 3.0, 3000.0),
        "array16_0.8h": _array(4, 4, 2.4, 3.0, 2500.0),
        "array20_1.2h": _array(5, 4, 3.0, 2.5, 3000.0),
        "array12_mixed": _array(4, 3, 2.7, 3.0, lambda i, j: mixed[(i + j) % 3]),
        "cluster4_0.3h": _cluster((6.0, 5.0, 3.0), (3.0, 2.5), 4, 0.9, 2500.0, 3.0),
        "cluster3_mixed": _cluster((6.0, 5.0, 3.0), (3.1, 2.4), 3, 0.9, [1500, 2500, 4000],
                                   3.0),
    }


#: the bound's and the truth refit's radiosity gather (numpy: 50 s at 20 000 points, the
#: same form factors as OpenCL's to float32)
BACKEND = "auto"


#: :func:`build`: the truth render's gather matrix is kept up to this size (MB), beyond it
#: recomputed in row chunks (the same numbers, bounded memory)
GATHER_MAX_MB = 128


def build(name, noise, seed=0, cell=0.2):
    """(scene with noisy rendered targets, true luminaires)."""
    (w, d, h), lums = scenes()[name]
    scene = g.with_reflectances(g.box_room((w, d, h), cell=cell))
    # the render's own gather (exact at every vertex) in row chunks of bounded memory,
    # not its (vertices x patches) matrix kept (816 MB at 170 000 vertices)
    from invrad_wb import constants as C
    keep, C.RADIOSITY_GATHER_MAX_MB = C.RADIOSITY_GATHER_MAX_MB, GATHER_MAX_MB
    try:
        lux = render(scene, lums, interreflection=True)
    finally:
        C.RADIOSITY_GATHER_MAX_MB = keep
    from invrad_wb.core.forward.radiosity import RadiosityModel
    RadiosityModel.forget(scene)
    if noise > 0:
        rng = np.random.default_rng(seed)
        lux = lux * np.clip(1.0 + noise * rng.standard_normal(len(lux)), 0.0, None)
    return scene.with_vertex_lux(lux), lums


def _vertex_problem(scene, true, free):
    """The last refit's problem (every target vertex, at most VERTEX_POINTS_MAX, the
    default settings, exact interreflection) and a function luminaires -> its Lights
    (snapped to the room's surfaces, their interreflection computed there)."""
    from invrad_wb.core.inverse.locate import LocateSettings
    from invrad_wb.core.inverse.locate_fit import _rebase
    from invrad_wb.core.inverse.locate_placement import _occluders, _snap_to_surfaces
    from invrad_wb.core.inverse.locate_problem import _refine_problem, vertex_points
    from invrad_wb.core.inverse.refine import Light
    from invrad_wb.core.inverse.votemaps import build_canvas
    from invrad_wb.core.inverse import locate_problem as lp
    from invrad_wb.core.inverse import locate_vertices as lv
    s = LocateSettings()
    room = int(scene.rooms[0])
    canvas = build_canvas(scene, room, pixel=s.pixel_m, dummy=False)
    flux = true[0].flux_lm
    pts = vertex_points(scene, most=lp.VERTEX_POINTS_MAX)
    base, ind = _refine_problem(scene, pts, canvas, _occluders(scene, s), s,
                                flux, BACKEND, True, {"radiosity": 0.0})
    base.free_flux = free
    # each luminaire's interreflection follows its position in the model and the Fisher
    # information (as in locate's last refit)
    base.indirect_gradient = True
    every = vertex_points(scene, most=lv.VERTICES_MAX)
    prob = base
    if len(every) > len(pts):
        # every vertex, streamed (as locate's last refit: locate_fit.polish_every_vertex)
        prob = lv.VertexProblem(every, base, pts.plane, indirect_model=ind)

    def lights(lums):
        out = []
        for t in lums:
            L = Light("free", np.asarray(t.position, float), np.array([0, 0, -1.0]), -1,
                      flux_scale=t.flux_lm / flux, free_flux=free)
            out.append(_snap_to_surfaces([L], canvas, scene)[0])
        return _rebase(base, out)
    return prob, lights


def bound(scene, true, noise, free, per_luminaire=False):
    """The Cramer-Rao bound of the true luminaires on every target vertex of ``scene``
    (:func:`invrad_wb.core.inverse.fitcheck.position_sd`, the noise ``noise``, fluxes free
    or given): (worst position sd (cm), worst flux sd (%) or nan, root mean square of the
    luminaires' position sd (cm)), and with ``per_luminaire`` the (K,) position sd (cm)
    and flux sd (%) of each true luminaire too. No unbiased estimate from these data does
    better; an error of 2-3 sd in the worst of a dozen luminaires is ordinary.

    The noise: bench's :func:`build` multiplies each vertex's value by 1 + noise x N(0, 1),
    so the log residual the refinement fits has a standard deviation of about ``noise``
    per vertex, independent from vertex to vertex (what position_sd assumes)."""
    from invrad_wb.core.inverse.fitcheck import position_sd
    from invrad_wb.core.inverse import locate_vertices as lv
    prob, lights = _vertex_problem(scene, true, free)
    sd_of = lv.position_sd if isinstance(prob, lv.VertexProblem) else position_sd
    sd, fsd = sd_of(prob, lights(true), sigma=max(noise, 1e-12))
    out = (100.0 * float(sd.max()), (100.0 * float(fsd.max()) if fsd is not None
                                     else float("nan")),
           100.0 * float(np.sqrt(np.mean(sd ** 2))))
    if per_luminaire:
        return out + (100.0 * sd, None if fsd is None else 100.0 * fsd)
    return out


def truth_refit(scene, true, found, noise, free):
    """Which errors are the data's and which the search's: the last refit's problem
    (every target vertex) refitted from the TRUE arrangement and from the found one,
    each as locate's last refit does (Levenberg-Marquardt, interreflection refreshed).
    Returns (chi-square gap, truth-refit's (K,) errors (cm), its (K,) flux errors (%)):
    the gap is 2 k (cost(found) - cost(truth refitted)) / noise^2 (k target vertices;
    the cost is half the area-weighted mean square log residual there), in units of the
    noise variance: > 0 (beyond a few) the truth's basin fits the data better, a search
    fault (a local minimum); <= 0 the found answer fits at least as well, the error is
    the data's (what the most likely arrangement near the truth is off, itself beyond
    the bound where the likelihood is not quadratic: close luminaires with free fluxes)."""
    prob, lights = _vertex_problem(scene, true, free)

    def refit(ls):
        for _ in range(4):
            ls, _c = prob.levenberg_marquardt(ls, iterations=100)
            ls, changed = prob.refresh_indirect(ls, moved=0.005)
            if not changed:
                break
        return ls, prob.cost(ls)
    start = lights(true)
    if hasattr(prob, "exact_indirect"):
        prob.exact_indirect(start)
    T, ct = refit(start)
    cf = float("nan")
    if found:
        F = lights(found)
        if hasattr(prob, "exact_indirect"):
            prob.exact_indirect(F)
        cf = prob.cost(F)
    gap = 2.0 * len(prob.target) * (cf - ct) / max(noise, 1e-12) ** 2
    err = np.array([100.0 * float(np.linalg.norm(L.position - t.position))
                    for L, t in zip(T, true)])
    ferr = np.array([100.0 * (L.flux_scale * prob.flux / t.flux_lm - 1.0)
                     for L, t in zip(T, true)])
    return gap, err, ferr


def per_luminaire(found, true):
    """For each true luminaire, (position error cm, flux error %) of the found luminaire
    paired with it (the pairing of least summed distance; nan when none is left)."""
    from scipy.optimize import linear_sum_assignment
    out = np.full((len(true), 2), np.nan)
    if not found:
        return out
    P = np.array([np.asarray(f.position, float) for f in found])
    Q = np.array([np.asarray(t.position, float) for t in true])
    D = np.linalg.norm(Q[:, None] - P[None], axis=2)
    for i, j in zip(*linear_sum_assignment(D)):
        out[i] = (100.0 * D[i, j], 100.0 * (found[j].flux_lm / true[i].flux_lm - 1.0))
    return out


def rms_error(found, true):
    """Root mean square distance (cm) from each true luminaire to the nearest found one.
    Against the bound's root mean square sd (each along its luminaire's worst direction):
    an efficient estimate gives a ratio between 1 and sqrt(2) (the error is 2-D)."""
    if not found:
        return float("nan")
    P = np.array([np.asarray(f.position, dtype=float) for f in found])
    d = [float(np.min(np.linalg.norm(P - t.position, axis=1))) for t in true]
    return 100.0 * float(np.sqrt(np.mean(np.square(d))))


def flux_errors(found, true):
    """Worst relative flux error (%) over true luminaires (each against its nearest)."""
    worst = 0.0
    for t in true:
        near = min(found, default=None,
                   key=lambda l: np.linalg.norm(np.asarray(l.position) - t.position))
        if near is None:
            return float("nan")
        worst = max(worst, abs(near.flux_lm / t.flux_lm - 1.0) * 100.0)
    return worst


def random_rooms(n, seed, kinds, noise):
    """Rooms never tuned on, located without the flux: per room the true count and
    fluxes, the count found, whether it is right, the worst position error (cm), the
    worst flux error (%) and locate's CPU s; then the summary."""
    from bench_random import random_scene
    rng = np.random.default_rng(seed)
    right, worst, worst_flux = 0, 0.0, 0.0
    for k in range(n):
        scene, lums, _dims = random_scene(rng, True)
        if kinds == 2:
            lums = [Luminaire(t.position, t.normal, t.flux_lm * (1.6 if i % 2 else 1.0))
                    for i, t in enumerate(lums)]
            lux = render(scene, lums, interreflection=True)
        else:
            lux = np.asarray(scene.vertex_lux, dtype=np.float64)
        rs = np.random.default_rng(k)
        lux = lux * np.clip(1.0 + noise * rs.standard_normal(len(lux)), 0.0, None)
        scene = scene.with_vertex_lux(lux)
        c0 = time.process_time()
        r = locate(scene, None)
        dc = time.process_time() - c0
        m = match(r.luminaires, lums)
        ok = m["found"] == m["true"] == len(r.luminaires)
        fe = flux_errors(r.luminaires, lums)
        right += ok
        worst, worst_flux = max(worst, m["max_error_cm"] or 0.0), max(worst_flux, fe)
        fl = "/".join(f"{f:.0f}" for f in sorted({t.flux_lm for t in lums}))
        print(f"{k:3d} {len(lums)} x {fl:>10s} lm  found {len(r.luminaires)}"
              f" {'yes' if ok else 'NO':>3s} {m['max_error_cm'] or float('nan'):7.2f} cm"
              f" {fe:7.2f} % {dc:6.1f} CPU s", flush=True)
    print(f"  count right {right}/{n}; worst {worst:.2f} cm; worst flux {worst_flux:.2f} %")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="")
    ap.add_argument("--noise", type=float, default=0.05)
    ap.add_argument("--no-flux-given", action="store_true", help="skip the flux-given runs")
    ap.add_argument("--given-only", action="store_true", help="only the flux-given runs")
    ap.add_argument("--cell", type=float, default=0.2,
                    help="the generator's mesh spacing (m): one target per vertex")
    ap.add_argument("--scene-cells", default="",
                    help="per scene its own mesh spacing, NAME=METRES,... (others: --cell)")
    ap.add_argument("--bound-only", action="store_true",
                    help="print the Cramer-Rao bounds of the scenes only (no locate)")
    ap.add_argument("--points-max", type=int, default=None,
                    help="target vertices of the last refit and of the bound (default:"
                         " locate_problem.VERTEX_POINTS_MAX); the votes keep their sample."
                         " At or above the room's vertex count the subset problem is the"
                         " whole room: no streamed refit, no interreflection gradient in"
                         " the last refit, each refresh a gather at every vertex (slow)")
    ap.add_argument("--cells", default="",
                    help="--bound-only: mesh spacings (m), comma-separated (default --cell)")
    ap.add_argument("--no-bound", action="store_true",
                    help="skip the Cramer-Rao bound after each run (sd columns print nan):"
                         " at fine meshes it costs as much as locate itself")
    ap.add_argument("--diagnose", action="store_true",
                    help="per luminaire: error, flux error, their bound (sd) and the"
                         " truth's own refit; per scene the chi-square gap of the found"
                         " answer to the truth's refit (truth_refit)")
    ap.add_argument("--random", type=int, default=0,
                    help="instead of the scenes: N rooms never tuned on (bench_random's"
                         " generator, seeded by --seed; 1-6 ceiling, wall and pendant"
                         " luminaires, interreflection, 0.1 m mesh) with --noise, located"
                         " without the flux")
    ap.add_argument("--seed", type=int, default=2027)
    ap.add_argument("--kinds", type=int, default=1, choices=(1, 2),
                    help="--random: luminaires of one flux, or two (every other one 1.6 x)")
    args = ap.parse_args()
    if args.random:
        random_rooms(args.random, args.seed, args.kinds, args.noise)
        return
    if args.points_max:
        from invrad_wb.core.inverse import locate_problem as lp
        lp.VERTEX_POINTS_MAX = args.points_max
    if args.bound_only:
        cells = [float(c) for c in args.cells.split(",")] if args.cells else [args.cell]
        for cell in cells:
            for name in [n for n in scenes() if not args.only or n in args.only.split(",")]:
                scene, true = build(name, args.noise, cell=cell)
                free = bound(scene, true, args.noise, True, per_luminaire=True)
                given = bound(scene, true, args.noise, False)
                print(f"{name:16s} {cell:5.3f} m {len(scene.vertices):6d} vertices flux free:"
                      f" {free[0]:6.2f} cm {free[1]:6.2f} %; flux given: {given[0]:6.2f} cm",
                      flush=True)
                if args.diagnose:
                    print("    free sd cm " + " ".join(f"{x:.2f}" for x in free[3])
                          + " | sd % " + " ".join(f"{x:.2f}" for x in free[4]), flush=True)
        return
    names = [n for n in scenes() if not args.only or n in args.only.split(",")]
    print(f"{'scene':16s} {'mode':6s} {'cell':>5s} {'vertices':>8s} {'count':>7s} {'ok':>3s}"
          f" {'max cm':>7s} {'max flux %':>10s} {'s':>7s} {'cpu s':>7s} {'rss MB':>6s}"
          f" {'sd cm':>6s} {'sd %':>6s} {'rms/sd':>6s}"
          + (f" {'gap chi2':>9s}" if args.diagnose else ""))
    summary = {"free": [], "given": []}
    per_scene = dict(c.split("=") for c in args.scene_cells.split(",") if c)
    for name in names:
        cell = float(per_scene.get(name, args.cell))
        scene, true = build(name, args.noise, cell=cell)
        rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        print(f"  {name}: {len(scene.vertices)} vertices at {cell} m, built; peak RSS so far"
              f" {rss0:.0f} MB", flush=True)
        modes = [] if args.given_only else [("free", None)]
        if not args.no_flux_given and len({t.flux_lm for t in true}) == 1:
            modes.append(("given", true[0].flux_lm))
        for mode, flux in modes:
            t0, c0 = time.perf_counter(), time.process_time()
            r = locate(scene, flux)
            dt, dc = time.perf_counter() - t0, time.process_time() - c0
            m = match(r.luminaires, true)
            ok = m["found"] == m["true"] == len(r.luminaires)
            fe = flux_errors(r.luminaires, true)
            cm = m["max_error_cm"] if m["max_error_cm"] is not None else float("nan")
            summary[mode].append((ok, cm, fe, dt))
            # What locate found, before the bound (which can take as long again at a fine
            # mesh): a run stopped in the bound still leaves its figures.
            print(f"  {name} {mode}: located {len(r.luminaires)}/{len(true)}, worst"
                  f" {cm:.2f} cm, flux {fe:.2f} %, {dt:.1f} s ({dc:.1f} CPU s)", flush=True)
            if args.no_bound:
                nan = float("nan")
                sd, fsd, sd_rms, sds, fsds = nan, nan, nan, np.full(len(true), nan), None
            else:
                sd, fsd, sd_rms, sds, fsds = bound(scene, true, args.noise, mode == "free",
                                                   per_luminaire=True)
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
            line = (f"{name:16s} {mode:6s} {cell:5.3f} {len(scene.vertices):8d}"
                    f" {len(r.luminaires):>3d}/{len(true):<3d}"
                    f" {'yes' if ok else 'NO':>3s} {cm:7.2f} {fe:10.2f} {dt:7.1f} {dc:7.1f}"
                    f" {rss:6.0f}"
                    f" {sd:6.2f} {fsd:6.2f} {rms_error(r.luminaires, true) / sd_rms:6.2f}")
            if not args.diagnose:
                print(line, flush=True)
                continue
            gap, terr, tferr = truth_refit(scene, true, r.luminaires, args.noise,
                                           mode == "free")
            print(line + f" {gap:9.1f}", flush=True)
            pl = per_luminaire(r.luminaires, true)
            for i, t in enumerate(true):
                fl = (f" flux {pl[i, 1]:7.2f} % (sd {fsds[i]:5.2f}, truth refit"
                      f" {tferr[i]:6.2f})" if fsds is not None else "")
                print(f"    {i:2d} {t.flux_lm:6.0f} lm  {pl[i, 0]:6.2f} cm (sd {sds[i]:5.2f},"
                      f" truth refit {terr[i]:6.2f}){fl}", flush=True)
    for mode, rows in summary.items():
        if rows:
            print(f"  {mode}: count right {sum(r[0] for r in rows)}/{len(rows)};"
                  f" worst {np.nanmax([r[1] for r in rows]):.2f} cm;"
                  f" worst flux {np.nanmax([r[2] for r in rows]):.2f} %;"
                  f" total {sum(r[3] for r in rows):.1f} s")


if __name__ == "__main__":
    main()
