if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {
  set terminal pngcairo size 960,540 noenhanced
} else {
  set terminal png size 960,540 noenhanced
}
set datafile missing 'NaN'
set output 'docs/acceptance/6d75fa3-dev-ur7e-lib1-report/success.png'
set title 'Success rate per arm and cell (Wilson 95 % intervals)'
set ylabel 'success (%)'
set yrange [0:105]
set grid ytics
set key outside right top
set style data histograms
set style histogram errorbars gap 2 lw 1
set style fill solid 0.6 border -1
plot 'docs/acceptance/6d75fa3-dev-ur7e-lib1-report/success.dat' using 2:3:4:xtic(1) title 'full'
reset
set output 'docs/acceptance/6d75fa3-dev-ur7e-lib1-report/wall_clock.png'
set title 'Episode wall clock per arm and cell'
set ylabel 'wall clock (s)'
set grid ytics
unset key
set xtics rotate by -30
set style data boxplot
set style fill solid 0.3 border -1
set boxwidth 0.5
set pointsize 0.5
plot 'docs/acceptance/6d75fa3-dev-ur7e-lib1-report/wall_clock.dat' using (1):2:(0.5):1
reset
set output 'docs/acceptance/6d75fa3-dev-ur7e-lib1-report/budget.png'
set title 'Budget used at the episode''s end, by arm and outcome'
set ylabel 'budget used (%)'
set yrange [0:105]
set grid ytics
unset key
set xtics rotate by -30
set style data boxplot
set style fill solid 0.3 border -1
set boxwidth 0.5
set pointsize 0.5
plot 'docs/acceptance/6d75fa3-dev-ur7e-lib1-report/budget.dat' using (1):2:(0.5):1
set output
