set terminal pngcairo size 900,560 noenhanced
set output 'case1_response_harmonics.png'
set datafile separator ','
set grid
set key outside right top
set title 'Case 1: test case, EO3, N0 = 5 N, f = 2 N'
set xlabel 'frequency [Hz]'
set ylabel 'response amplitude [m]'
set logscale y
set format y '%.0e'
plot '../../../out/case_studies/test_case_1/runs/0000/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'H = 1', \
     '../../../out/case_studies/test_case_1/runs/0001/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'H = 3', \
     '../../../out/case_studies/test_case_1/runs/0002/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'H = 5', \
     '../../../out/case_studies/test_case_1/runs/0003/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'H = 10', \
     '../../../out/case_studies/test_case_1_free/response.csv' using 'frequency_hz':'response_amplitude_m' with lines lw 2 title 'no contact'
