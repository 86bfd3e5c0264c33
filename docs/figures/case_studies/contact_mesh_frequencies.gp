set terminal pngcairo size 1000,480 noenhanced
set output 'contact_mesh_frequencies.png'
set datafile separator ','
set grid
set key below
set logscale x 2
set xlabel 'contact node pairs per face'
set ylabel 'frequency [Hz]'
set multiplot layout 1,2
set title '1F, case 1'
plot 'contact_mesh_case1.csv' using 'pairs':'free_hz' with linespoints pt 6 title 'free', \
     'contact_mesh_case1.csv' using 'pairs':'stuck_hz' with linespoints pt 4 title 'stuck', \
     'contact_mesh_case1.csv' using 'pairs':'peak_frequency_hz' with linespoints lw 2 pt 7 title 'peak'
set title '1T, case 2'
plot 'contact_mesh_case2.csv' using 'pairs':'free_hz' with linespoints pt 6 title 'free', \
     'contact_mesh_case2.csv' using 'pairs':'stuck_hz' with linespoints pt 4 title 'stuck', \
     'contact_mesh_case2.csv' using 'pairs':'peak_frequency_hz' with linespoints lw 2 pt 7 title 'peak', \
     'contact_mesh_case2_tilted.csv' using 'pairs':'peak_frequency_hz' with linespoints lw 2 pt 7 title 'peak, tilted preload'
unset multiplot
