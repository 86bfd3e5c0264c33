set terminal pngcairo size 900,560 noenhanced
set output 'large_case_3.png'
set datafile separator ','
set grid
set key outside right top
set title 'large case 3'
set xlabel 'frequency [Hz]'
set ylabel 'response amplitude [m]'
set logscale y
set format y '%.0e'
plot '../../../out/case_studies/large_case_3/runs/0000/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 50 um, N0 = 0 N, H = 1', \
     '../../../out/case_studies/large_case_3/runs/0001/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 50 um, N0 = 0 N, H = 2', \
     '../../../out/case_studies/large_case_3/runs/0002/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 50 um, N0 = 0 N, H = 5', \
     '../../../out/case_studies/large_case_3/runs/0003/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 50 um, N0 = 0 N, H = 10', \
     '../../../out/case_studies/large_case_3/runs/0004/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 0 um, N0 = 5 N, H = 1', \
     '../../../out/case_studies/large_case_3/runs/0005/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 0 um, N0 = 5 N, H = 2', \
     '../../../out/case_studies/large_case_3/runs/0006/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 0 um, N0 = 5 N, H = 5', \
     '../../../out/case_studies/large_case_3/runs/0007/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 0 um, N0 = 5 N, H = 10', \
     '../../../out/case_studies/large_case_3/runs/0008/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 0 um, N0 = 10 N, H = 1', \
     '../../../out/case_studies/large_case_3/runs/0009/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 0 um, N0 = 10 N, H = 2', \
     '../../../out/case_studies/large_case_3/runs/0010/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 0 um, N0 = 10 N, H = 5', \
     '../../../out/case_studies/large_case_3/runs/0011/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'gap 0 um, N0 = 10 N, H = 10'
