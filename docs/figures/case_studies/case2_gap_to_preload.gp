set terminal pngcairo size 900,560 noenhanced
set output 'case2_gap_to_preload.png'
set datafile separator ','
set grid
set key outside right top
set title 'Case 2: test case, EO1, 1T, gap to preload'
set xlabel 'frequency [Hz]'
set ylabel 'shroud_right amplitude [m]'
set logscale y
set format y '%.0e'
plot '../../../out/case_studies/test_case_2/runs/0000/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'gap 1000 um', \
     '../../../out/case_studies/test_case_2/runs/0001/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'gap 1 um', \
     '../../../out/case_studies/test_case_2/runs/0002/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'gap 0.5 um', \
     '../../../out/case_studies/test_case_2/runs/0003/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'gap 0.25 um', \
     '../../../out/case_studies/test_case_2/runs/0004/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'gap 0.1 um', \
     '../../../out/case_studies/test_case_2/runs/0005/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 0 N', \
     '../../../out/case_studies/test_case_2/runs/0006/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 0.25 N', \
     '../../../out/case_studies/test_case_2/runs/0007/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 0.5 N', \
     '../../../out/case_studies/test_case_2/runs/0008/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 1 N', \
     '../../../out/case_studies/test_case_2/runs/0009/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 2.5 N', \
     '../../../out/case_studies/test_case_2/runs/0010/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 5 N', \
     '../../../out/case_studies/test_case_2/runs/0011/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 10 N', \
     '../../../out/case_studies/test_case_2/runs/0012/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 25 N', \
     '../../../out/case_studies/test_case_2/runs/0013/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 50 N', \
     '../../../out/case_studies/test_case_2/runs/0014/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'N0 = 200 N', \
     '../../../out/case_studies/test_case_2_free/response.csv' using 'frequency_hz':'shroud_right_amplitude_m' with lines lw 2 title 'no contact'
