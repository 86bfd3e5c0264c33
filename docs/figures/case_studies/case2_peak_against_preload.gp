set terminal pngcairo size 900,560 noenhanced
set output 'case2_peak_against_preload.png'
set datafile separator ','
set grid
set key outside right top
set title 'Case 2: peak against the preload'
set xlabel 'normal preload N0 [N]'
set ylabel 'shroud_right peak amplitude [m]'
set logscale y
set format y '%.0e'
set logscale x
plot '../../../out/case_studies/test_case_2/study.csv' using (column(3) > 0 ? column(3) : 1/0):'shroud_right_peak_amplitude_m' with linespoints pt 7 lw 2 title 'preloaded'
