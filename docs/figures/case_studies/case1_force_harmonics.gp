set terminal pngcairo size 900,560 noenhanced
set output 'case1_force_harmonics.png'
set datafile separator ','
set grid
set key outside right top
set title 'Case 1: harmonics of the shroud friction force'
set xlabel 'harmonic'
set ylabel 'amplitude [N]'
set xtics 1
set xrange [-0.5:10.5]
plot '../../../out/case_studies/test_case_1/runs/0002/loops/shroud_90Hz_1_harmonics.csv' using ($1 + -0.1):'f_t1_amplitude_N' with impulses lw 6 title 'tangential, 90 Hz, crossing 1', \
     '../../../out/case_studies/test_case_1/runs/0002/loops/shroud_118.5Hz_1_harmonics.csv' using ($1 + 0.1):'f_t1_amplitude_N' with impulses lw 6 title 'tangential, 118.5 Hz, crossing 1', \
     '../../../out/case_studies/test_case_1/runs/0002/loops/shroud_118.5Hz_2_harmonics.csv' using ($1 + 0.30000000000000004):'f_t1_amplitude_N' with impulses lw 6 title 'tangential, 118.5 Hz, crossing 2', \
     '../../../out/case_studies/test_case_1/runs/0002/loops/shroud_118.5Hz_3_harmonics.csv' using ($1 + 0.5000000000000001):'f_t1_amplitude_N' with impulses lw 6 title 'tangential, 118.5 Hz, crossing 3'
