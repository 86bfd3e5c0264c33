set terminal pngcairo size 900,560 noenhanced
set output 'large_case_3_excitation_levels.png'
set datafile separator ','
set grid
set key outside right top
set title 'large case 3 excitation levels'
set xlabel 'frequency [Hz]'
set ylabel 'response amplitude / force [m/N]'
set logscale y
set format y '%.0e'
plot '../../../out/case_studies/large_case_3_excitation_levels/runs/0000/response.csv' using 'frequency_hz':(column('response_amplitude_m') / 0.03) with lines lw 2 title 'f = 0.03 N', \
     '../../../out/case_studies/large_case_3_excitation_levels/runs/0001/response.csv' using 'frequency_hz':(column('response_amplitude_m') / 0.1) with lines lw 2 title 'f = 0.1 N', \
     '../../../out/case_studies/large_case_3_excitation_levels/runs/0002/response.csv' using 'frequency_hz':(column('response_amplitude_m') / 0.3) with lines lw 2 title 'f = 0.3 N', \
     '../../../out/case_studies/large_case_3_excitation_levels/runs/0003/response.csv' using 'frequency_hz':(column('response_amplitude_m') / 1.0) with lines lw 2 title 'f = 1 N', \
     '../../../out/case_studies/large_case_3_excitation_levels/runs/0004/response.csv' using 'frequency_hz':(column('response_amplitude_m') / 3.0) with lines lw 2 title 'f = 3 N', \
     '../../../out/case_studies/large_case_3_excitation_levels/runs/0005/response.csv' using 'frequency_hz':(column('response_amplitude_m') / 10.0) with lines lw 2 title 'f = 10 N'
