set terminal pngcairo size 900,560 noenhanced
set output 'large_case_3_friction.png'
set datafile separator ','
set grid
set key outside right top
set title 'large case 3 friction'
set xlabel 'frequency [Hz]'
set ylabel 'response amplitude [m]'
set logscale y
set format y '%.0e'
plot '../../../out/case_studies/large_case_3_friction/runs/0000/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.05', \
     '../../../out/case_studies/large_case_3_friction/runs/0001/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.1', \
     '../../../out/case_studies/large_case_3_friction/runs/0002/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.2', \
     '../../../out/case_studies/large_case_3_friction/runs/0003/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.3', \
     '../../../out/case_studies/large_case_3_friction/runs/0004/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.5', \
     '../../../out/case_studies/large_case_3_friction/runs/0005/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.8'
