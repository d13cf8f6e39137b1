/* swell-bench: the gnuplot script and the plots drawn from the CSV files (plots.gp and the PNGs). */
#include <string.h>
#include <sys/stat.h>

#include "bench.h"

int write_plots(const struct opts *o)
{
	FILE *fp = open_out(o, "plots.gp");
	char cmd[4200];
	int k, rc;

	fprintf(fp,
		"# gnuplot script written by swell-bench; run from this directory: gnuplot plots.gp\n"
		"set datafile separator ','\n"
		"set terminal pngcairo size 900,600 font ',10'\n"
		"set key outside right\n"
		"set grid\n"
		"set format y '10^{%%L}'\n"
		"set output 'pareto.png'\n"
		"set title 'Run time against error: (1,1) mode of 1 mm, t = 0; every grid, e and stencil'\n"
		"set logscale xy\n"
		"set xrange [0.2:60]\n"
		"set xlabel 'host cost per cell-step, relative to float32 measured in the same run'\n"
		"set ylabel 'L-inf error against the exact discrete eigenmode (mm)'\n"
		"set key bottom right inside font ',9'\n"
		"impls = '");
	for (k = 0; k < BENCH_IMPL_COUNT; k++)
		fprintf(fp, "%s%s", k ? " " : "", bench_impl_name((enum bench_impl)k));
	fprintf(fp,
		"'\n"
		"plot for [i=1:words(impls)] 'matrix.csv' using (strcol(1) eq word(impls,i) ? $10 : 1/0):"
		"($15 > 1e-16 ? $15 : 1e-16) with points pt i ps 1.3 title word(impls,i), \\\n"
		"     'matrix.csv' using ($24 == 1 && $3 == 64 && $5 > 0.19 && $5 < 0.21 ? $10 : 1/0):"
		"($15 > 1e-16 ? $15 : 1e-16) with points pt 6 ps 3 lc 'black' title "
		"'fixed-point Pareto front, 64x64 e = 0.2'\n"
		"set autoscale x\n"
		"unset logscale\n"
		"set output 'error_steps.png'\n"
		"set title 'Error against steps (64x64, e = 0.2, t = 0; L-inf vs float64 of the same scheme)'\n"
		"set logscale xy\n"
		"set xlabel 'steps'\n"
		"set ylabel 'L-inf (mm)'\n"
		"set multiplot layout 1,2\n"
		"set key bottom right inside font ',8'\n");
	for (k = 0; k < 2; k++) /* the paper stencil's, then the calibrated one's (index 0, 1) */
		fprintf(fp,
			"set title '%s stencil'\n"
			"plot for [i=1:words(impls)-1] 'error_steps.csv' index %d using (strcol(1) eq word(impls,i) ? "
			"$5 : 1/0):($6 > 1e-16 ? $6 : 1e-16) with linespoints pt i title word(impls,i), "
			"'error_steps.csv' index %d using (strcol(1) eq 'ef32' ? $5 : 1/0):($10 > 1e-16 ? $10 : "
			"1/0) with lines dt 2 lc 'black' title 'discretisation (vs seiche)'\n",
			k ? "calibrated" : "paper", k, k);
	fprintf(fp,
		"unset multiplot\n"
		"unset logscale\n"
		"set key outside right\n"
		"set format y '%%g'\n"
		"set output 'stability.png'\n"
		"set title 'Stability map, paper stencil (16x16 noise; filled = bounded)'\n"
		"set xlabel 'damping t'\n"
		"set ylabel 'e_{eff}'\n"
		"set xrange [-0.02:0.77]\n"
		"set yrange [0.28:1.35]\n"
		"set samples 200\n"
		"lim(t) = (2 - t) / (4 * (1 - t))\n"
		"plot 'stability.csv' index 0 using ($5 == 1 ? $2 : 1/0):3 with points pt 7 ps 0.9 lc "
		"'dark-green' title 'ef32 bounded', \\\n"
		"     'stability.csv' index 0 using ($5 == 0 ? $2 : 1/0):3 with points pt 6 ps 0.9 lc 'red' "
		"title 'ef32 unbounded', \\\n"
		"     'stability.csv' index 1 using ($5 == 1 ? $2 : 1/0):($3 + 0.006) with points pt 1 ps 0.5 "
		"lc 'blue' title 'f64 bounded', \\\n"
		"     'boundary.csv' using 1:3 with linespoints pt 9 ps 1.5 lc 'black' title 'measured "
		"boundary (ef32)', \\\n"
		"     lim(x) with lines lw 2 lc 'orange' title 'analytic (1+q)/(4q)'\n");
	fclose(fp);
	if (strchr(o->out, '\'')) {
		progress("output path contains a quote; run gnuplot plots.gp there by hand");
		return -1;
	}
	snprintf(cmd, sizeof(cmd), "cd '%s' && gnuplot plots.gp", o->out);
	rc = system(cmd);
	if (rc != 0) {
		progress("gnuplot failed (exit %d); CSV files are complete, plots not made", rc);
		return -1;
	}
	progress("plots: %s/pareto.png, error_steps.png, stability.png", o->out);
	return 0;
}

const char *missing_results(const struct opts *o)
{
	static const char *const need[] = { "matrix.csv", "error_steps.csv", "stability.csv", "boundary.csv" };
	char path[4096];
	struct stat st;
	size_t k;

	for (k = 0; k < sizeof(need) / sizeof(need[0]); k++) {
		snprintf(path, sizeof(path), "%s/%s", o->out, need[k]);
		if (stat(path, &st) != 0 || st.st_size == 0)
			return need[k];
	}
	return NULL;
}
