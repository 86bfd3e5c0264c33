set terminal pngcairo size 900,560 noenhanced
set datafile separator ','
set grid
set key below
set logscale x 2
set xlabel 'contact node pairs per face'
set output 'contact_mesh_peaks.png'
set logscale y
set format y '%.0e'
set title 'Peak amplitude against the reference (limit or finest mesh)'
set ylabel '|peak / reference - 1|'
plot 'contact_mesh_case1.csv' using 'pairs':'abs_peak_vs_reference' with linespoints lw 2 pt 7 title 'case 1 (EO3, 1D friction, N0 = 5 N)', \
     'contact_mesh_case2.csv' using 'pairs':'abs_peak_vs_reference' with linespoints lw 2 pt 7 title 'case 2 (EO1, 3D coupled friction, N0 = 1 N)', \
     'contact_mesh_case2_tilted.csv' using 'pairs':'abs_peak_vs_reference' with linespoints lw 2 pt 7 title 'case 2, N0 = 1 N varying 9:1 over the face', 0.01 with lines dt 2 lc rgb 'black' title '1 %'
