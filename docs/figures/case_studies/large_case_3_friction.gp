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
plot '../../../../../tmp/diag/s8/cs2/large_case_3_friction/runs/0000/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.05', \
     '../../../../../tmp/diag/s8/cs2/large_case_3_friction/runs/0001/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.1', \
     '../../../../../tmp/diag/s8/cs2/large_case_3_friction/runs/0002/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.2', \
     '../../../../../tmp/diag/s8/cs2/large_case_3_friction/runs/0003/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.3', \
     '../../../../../tmp/diag/s8/cs2/large_case_3_friction/runs/0004/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.5', \
     '../../../../../tmp/diag/s8/cs2/large_case_3_friction/runs/0005/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'mu = 0.8'
