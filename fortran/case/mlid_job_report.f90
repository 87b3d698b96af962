!> The printed report and the JSON object of the jobs of mlid_jobs
!> (simulate, design, monte_carlo), built once as text for both front ends.
module mlid_job_report
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp
  use mlid_text, only: itoa, es_text
  use mlid_case, only: ONLINE_ESTIMATORS
  use mlid_report, only: case_json, json_string, number, numbers, strings, matrix
  use mlid_input_ranking, only: ranking_t
  implicit none
  private
  public :: design_summary_t, design_report, design_json, mc_summary_t, mc_report, mc_json, &
            simulate_report, simulate_json, input_summary_t, online_summary_t, online_report, &
            online_json

  character, parameter :: NL = achar(10)
  !> The report's words for each of mlid_case's ONLINE_ESTIMATORS.
  character(len=48), parameter :: ESTIMATOR_WORDS(size(ONLINE_ESTIMATORS)) = [character(len=48) :: &
    'Fourier-transform regression', 'extended Kalman filter (augmented state)', &
    'unscented Kalman filter (augmented state)', 'unscented Kalman filter (augmented noise)', &
    'extended forgetting-factor least squares', 'recursive least squares']

  !> One input of a simulation: its shape ('file' when read from
  !> input_file), peak |u|, rms, relative peak factor (max - min)/(2 sqrt(2)
  !> rms) and, for a multisine or a sweep, its frequencies [Hz].
  type :: input_summary_t
    character(len=32) :: name = '', shape = ''
    real(wp) :: peak = 0.0_wp, rms = 0.0_wp, rpf = 0.0_wp
    real(wp), allocatable :: freq(:)
  end type input_summary_t

  !> An online estimator's history (at each point: t, the estimates est and
  !> sigma sig (np, m), its own measure s2: FTR each equation's residual
  !> variance, a filter R's diagonal), its settings and when each estimate
  !> converged.
  type :: online_summary_t
    character(len=16) :: estimator = ''
    character(len=32) :: measure = ''        !< what s2 holds, for the report
    character(len=:), allocatable :: settings  !< the estimator's settings in words
    character(len=32), allocatable :: names(:)
    real(wp), allocatable :: t(:), est(:, :), sig(:, :), s2(:, :), converged(:)
    integer :: samples = 0
    character(len=512) :: out = ''
    real(wp) :: per_sample = -1.0_wp   !< the estimator's seconds a sample (< 0: not timed)
    real(wp) :: dt = 0.0_wp            !< the record's mean sampling interval
  end type online_summary_t

  !> A designed input and its information (unknowns in the case's order).
  type :: design_summary_t
    character(len=16) :: method = ''
    character(len=32), allocatable :: labels(:), inputs(:)
    real(wp), allocatable :: weights(:), servo(:), mm(:, :), sigma(:), eig(:), ratios(:)
    real(wp) :: t = 0.0_wp, energy = 0.0_wp, peak = 0.0_wp, mu = 0.0_wp, det = 0.0_wp
    real(wp) :: trace = 0.0_wp
    integer :: cells = 0, samples = 0, nratio = 0
    logical :: noise = .false.          !< designed with process noise (§7.5)
    !> the state penalty K of §7.6 (not allocated: none), and under the
    !> input int x'Kx dt and each state's peak |x| and rms
    real(wp), allocatable :: kx(:, :), xpeak(:), xrms(:)
    real(wp) :: xint = 0.0_wp
    character(len=512) :: out = ''
    !> the candidate inputs ranked beside it (none: no ranking), the labels
    !> of the states and outputs whose peak and rms it gives
    type(ranking_t) :: ranking
    character(len=32), allocatable :: states(:), outputs(:)
  end type design_summary_t

  !> The statistics of a Monte Carlo (free parameters, in the order of free).
  type :: mc_summary_t
    character(len=32), allocatable :: labels(:)
    real(wp), allocatable :: truth(:), start(:), mean(:), sample_sigma(:), cr_sigma(:)
    real(wp) :: cov_det = 0.0_wp, cov_trace = 0.0_wp, info_trace = 0.0_wp, info_det = 0.0_wp
    integer :: runs = 0, ok = 0, seed = 0, samples = 0
    character(len=512) :: input_file = ''
  end type mc_summary_t

contains

  !> The samples written and a line per input (shape, peak, rms, RPF and a
  !> multisine's harmonics or a sweep's band).
  function simulate_report(samples, out, inputs) result(text)
    integer, intent(in) :: samples
    character(len=*), intent(in) :: out
    type(input_summary_t), intent(in) :: inputs(:)
    character(len=:), allocatable :: text
    character(len=256) :: buf
    integer :: k, j
    text = ' simulated '//itoa(samples)//' samples to '//trim(out)//NL
    if (size(inputs) == 0) return
    write (buf, '(1x,a16,a12,3a14)') 'input           ', 'shape       ', 'peak', 'rms', 'RPF'
    text = text//trim(buf)//NL
    do k = 1, size(inputs)
      write (buf, '(1x,a16,a12)') inputs(k)%name, inputs(k)%shape
      text = text//trim(buf(1:29)//es_text(inputs(k)%peak, 14, 5)// &
                        es_text(inputs(k)%rms, 14, 5)//es_text(inputs(k)%rpf, 14, 5))
      if (size(inputs(k)%freq) > 0) then
        text = text//'   Hz:'
        do j = 1, size(inputs(k)%freq)
          text = text//' '//trim(adjustl(es_text(inputs(k)%freq(j), 10, 3)))
        end do
      end if
      text = text//NL
    end do
  end function simulate_report

  function simulate_json(title, job, samples, out, inputs) result(text)
    character(len=*), intent(in) :: title, job, out
    integer, intent(in) :: samples
    type(input_summary_t), intent(in) :: inputs(:)
    character(len=:), allocatable :: text
    integer :: k
    text = case_json(title, job, 0, '', samples, trim(out))
    text = text(1:len(text) - 1)//','//NL//'"inputs": ['
    do k = 1, size(inputs)
      if (k > 1) text = text//','
      text = text//NL//'{"name": '//json_string(trim(inputs(k)%name))//', "shape": '// &
             json_string(trim(inputs(k)%shape))//', "peak": '//number(inputs(k)%peak)// &
             ', "rms": '//number(inputs(k)%rms)//', "rpf": '//number(inputs(k)%rpf)// &
             ', "frequencies_hz": '//numbers(inputs(k)%freq)//'}'
    end do
    text = text//']}'
  end function simulate_json

  !> The method and its limit, the unknowns' weights and Cramer-Rao sigma,
  !> tr M, det M and the eigenvalues, and where the input went.
  function design_report(s) result(text)
    type(design_summary_t), intent(in) :: s
    character(len=:), allocatable :: text
    character(len=256) :: buf
    integer :: k

    text = ' input design, method '''//trim(s%method)//''' (report ch. 7): T = '// &
           es_text(s%t, 10, 4)//' s, '//itoa(s%cells)//' cells of '// &
           es_text(s%t/s%cells, 10, 4)//' s'//NL
    do k = 1, size(s%servo)
      if (s%servo(k) > 0.0_wp) then
        text = text//' servo on '//trim(s%inputs(k))//': first order, time constant '// &
               es_text(s%servo(k), 10, 4)//' s (the input is its command, report 8.3)'//NL
      end if
    end do
    if (s%noise) text = text//' process noise: the steady-state filter''s sensitivities '// &
                       '(report 7.5)'//NL
    if (allocated(s%kx)) text = text//penalty_lines(s)
    text = text//trim(' energy '//es_text(s%energy, 14, 7)//'   peak '//es_text(s%peak, 14, 7))
    if (ieee_is_finite(s%mu) .and. allocated(s%kx)) then
      text = text//'   mu '//es_text(s%mu, 14, 7)//' (max tr(WM) - int x''Kx dt = mu E)'
    else if (ieee_is_finite(s%mu)) then
      text = text//'   mu '//es_text(s%mu, 14, 7)//' (max tr(WM) = mu E)'
    end if
    text = text//NL
    if (s%nratio > 0) then
      write (buf, '(a,f0.4,a,f0.4,a,i0,a)') ' equalised weights (eq. 7.88): diag(WM) max/min ', &
        s%ratios(1), ' -> ', s%ratios(s%nratio), ' (', s%nratio - 1, ' updates kept)'
      text = text//trim(buf)//NL
    end if
    write (buf, '(1x,a16,a13,a15)') 'unknown         ', 'weight', 'sigma (CR)'
    text = text//trim(buf)//NL
    do k = 1, size(s%labels)
      write (buf, '(1x,a16)') s%labels(k)
      text = text//trim(buf(1:17)//es_text(s%weights(k), 13, 4)//es_text(s%sigma(k), 15, 6))//NL
    end do
    text = text//trim(' tr M = '//es_text(s%trace, 14, 7)//'   det M = '//es_text(s%det, 14, 7))// &
           NL//' eigenvalues of M:'
    do k = 1, size(s%eig)
      text = text//es_text(s%eig(k), 11, 4)
    end do
    text = text//NL//' designed input written to '//trim(s%out)//' ('//itoa(s%samples)// &
           ' samples)'//NL
    if (allocated(s%ranking%order)) text = text//ranking_report(s)
  end function design_report

  !> The candidates in rank order: det M, tr M and each unknown's sigma,
  !> then the peak and rms of each state and output under each.
  function ranking_report(s) result(text)
    type(design_summary_t), intent(in) :: s
    character(len=:), allocatable :: text
    character(len=256) :: buf
    integer :: k, j, c

    associate (r => s%ranking)
      text = ' candidate inputs at equal '//trim(r%compare)//' '//trim(adjustl(es_text(r%level, &
             14, 7)))//', ranked by '//trim(merge('det M (D-optimal)', 'tr M             ', &
             r%rank_by == 'det'))//'; s: Cramer-Rao sigma'//NL
      write (buf, '(1x,a4,2x,a10,2a13)') 'rank', 'candidate ', 'det M', 'tr M'
      text = text//trim(buf)
      do j = 1, size(s%labels)
        text = text//' '//adjustr(sigma_head(s%labels(j)))
      end do
      text = text//'  signal'//NL
      do k = 1, size(r%order)
        c = r%order(k)
        write (buf, '(1x,i4,2x,a10)') k, r%names(c)
        text = text//buf(1:17)//es_text(r%det(c), 13, 4)//es_text(r%trace(c), 13, 4)
        do j = 1, size(s%labels)
          text = text//' '//es_text(r%sigma(j, c), 13, 4)
        end do
        text = text//'  '//trim(r%detail(c))//NL
      end do
      write (buf, '(1x,a16)') 'peak, rms of'
      text = text//trim(buf)
      do k = 1, size(r%order)
        text = text//adjustr(r%names(r%order(k))(1:12))
      end do
      text = text//NL
      text = text//response_rows(s%states, r%x_peak, r%x_rms, r%order)// &
             response_rows(s%outputs, r%y_peak, r%y_rms, r%order)
    end associate
  end function ranking_report

  !> 'sigma label', at most 13 characters
  function sigma_head(label) result(head)
    character(len=*), intent(in) :: label
    character(len=13) :: head
    head = 's '//trim(label)
  end function sigma_head

  !> Two lines per name: its peak and its rms under each candidate, ranked.
  function response_rows(names, peak, rms, order) result(text)
    character(len=*), intent(in) :: names(:)
    real(wp), intent(in) :: peak(:, :), rms(:, :)
    integer, intent(in) :: order(:)
    character(len=:), allocatable :: text
    character(len=32) :: buf
    integer :: i, k

    text = ''
    do i = 1, size(names)
      write (buf, '(1x,a16)') 'peak '//names(i)
      text = text//buf(1:17)
      do k = 1, size(order)
        text = text//es_text(peak(i, order(k)), 12, 4)
      end do
      write (buf, '(1x,a16)') 'rms  '//names(i)
      text = text//NL//buf(1:17)
      do k = 1, size(order)
        text = text//es_text(rms(i, order(k)), 12, 4)
      end do
      text = text//NL
    end do
  end function response_rows

  function design_json(title, job, s) result(text)
    character(len=*), intent(in) :: title, job
    type(design_summary_t), intent(in) :: s
    character(len=:), allocatable :: text
    text = case_json(title, job, 0, '')
    text = text(1:len(text) - 1)//','//NL// &
           '"method": '//json_string(trim(s%method))//', "T": '//number(s%t)//', "cells": '// &
           itoa(s%cells)//','//NL// &
           '"unknowns": '//strings(s%labels)//','//NL// &
           '"weights": '//numbers(s%weights)//','//NL// &
           '"servo": '//numbers(s%servo)//', "process_noise": '// &
           trim(merge('true ', 'false', s%noise))//','//NL// &
           '"energy": '//number(s%energy)//', "peak": '//number(s%peak)//', "mu": '// &
           number(s%mu)//','//NL// &
           '"trace_M": '//number(s%trace)//', "det_M": '//number(s%det)//','//NL// &
           '"sigma": '//numbers(s%sigma)//','//NL// &
           '"eigenvalues": '//numbers(s%eig)//','//NL// &
           '"M": '//matrix(s%mm)//','//NL// &
           '"equalise_ratios": '//ratios()//','//NL//penalty()// &
           '"ranking": '//ranking_json(s)//','//NL// &
           '"samples": '//itoa(s%samples)//', "out": '//json_string(trim(s%out))//'}'

  contains

    function ratios() result(v)
      character(len=:), allocatable :: v
      v = 'null'
      if (s%nratio > 0) v = numbers(s%ratios(1:s%nratio))
    end function ratios

    function penalty() result(v)
      character(len=:), allocatable :: v
      v = ''
      if (allocated(s%kx)) v = '"state_penalty": '//matrix(s%kx)//', "state_integral_K": '// &
                               number(s%xint)//','//NL//'"state_peak": '//numbers(s%xpeak)// &
                               ', "state_rms": '//numbers(s%xrms)//','//NL
    end function penalty

  end function design_json

  !> The state penalty K of §7.6 and what it weighs under the input: K's
  !> rows, int x'Kx dt, each state's peak |x| and rms over T.
  function penalty_lines(s) result(text)
    type(design_summary_t), intent(in) :: s
    character(len=:), allocatable :: text
    character(len=256) :: buf
    integer :: i, j
    text = ' state penalty K (report 7.6: tr(WM) - int x''Kx dt maximised), row by row:'//NL
    do i = 1, size(s%kx, 1)
      text = text//' '
      do j = 1, size(s%kx, 2)
        text = text//es_text(s%kx(i, j), 12, 4)
      end do
      text = text//NL
    end do
    text = text//trim(' under the input: int x''Kx dt = '//es_text(s%xint, 14, 7))//NL
    write (buf, '(1x,a8,2a15)') 'state   ', 'peak |x|', 'rms x'
    text = text//trim(buf)//NL
    do i = 1, size(s%xpeak)
      write (buf, '(1x,a1,i0)') 'x', i
      text = text//trim(buf(1:9)//es_text(s%xpeak(i), 15, 6)//es_text(s%xrms(i), 15, 6))//NL
    end do
  end function penalty_lines

  !> The ranking as a JSON object, its lists in rank order (null: none).
  function ranking_json(s) result(text)
    type(design_summary_t), intent(in) :: s
    character(len=:), allocatable :: text
    integer :: k

    text = 'null'
    if (.not. allocated(s%ranking%order)) return
    associate (r => s%ranking, o => s%ranking%order)
      text = '{"compare": '//json_string(trim(r%compare))//', "level": '//number(r%level)// &
             ', "rank_by": '//json_string(trim(r%rank_by))//','//NL// &
             '"candidates": '//strings(r%names(o))//','//NL// &
             '"signals": '//strings(r%detail(o))//','//NL// &
             '"energy": '//numbers(r%energy(o))//', "peak": '//numbers(r%peak(o))//','//NL// &
             '"det_M": '//numbers(r%det(o))//','//NL// &
             '"trace_M": '//numbers(r%trace(o))//','//NL// &
             '"sigma": '//matrix(transpose(r%sigma(:, o)))//','//NL// &
             '"states": '//strings(s%states)//', "outputs": '//strings(s%outputs)//','//NL// &
             '"state_peak": '//matrix(transpose(r%x_peak(:, o)))//','//NL// &
             '"state_rms": '//matrix(transpose(r%x_rms(:, o)))//','//NL// &
             '"output_peak": '//matrix(transpose(r%y_peak(:, o)))//','//NL// &
             '"output_rms": '//matrix(transpose(r%y_rms(:, o)))//','//NL// &
             '"M": ['
      do k = 1, size(o)
        text = text//matrix(r%mm(:, :, o(k)))
        if (k < size(o)) text = text//', '
      end do
      text = text//']}'
    end associate
  end function ranking_json

  !> Runs and failures, then per free parameter truth, start, mean, sample
  !> sigma and mean Cramer-Rao sigma; the sample covariance and the mean
  !> information.
  function mc_report(s) result(text)
    type(mc_summary_t), intent(in) :: s
    character(len=:), allocatable :: text
    character(len=256) :: buf
    integer :: k

    text = ' Monte Carlo: '//itoa(s%runs)//' runs from seed '//itoa(s%seed)//', '// &
           itoa(s%runs - s%ok)//' failed; input from '//trim(s%input_file)//' ('// &
           itoa(s%samples)//' samples)'//NL
    write (buf, '(1x,a16,5a14)') 'parameter       ', 'truth', 'start', 'mean', 'sample sigma', &
      'mean CR sigma'
    text = text//trim(buf)//NL
    do k = 1, size(s%labels)
      write (buf, '(1x,a16)') s%labels(k)
      text = text//trim(buf(1:17)//es_text(s%truth(k), 14, 5)//es_text(s%start(k), 14, 5)// &
             es_text(s%mean(k), 14, 5)//es_text(s%sample_sigma(k), 14, 5)// &
             es_text(s%cr_sigma(k), 14, 5))//NL
    end do
    text = text//trim(' sample covariance: det '//es_text(s%cov_det, 12, 5)//'   trace '// &
                      es_text(s%cov_trace, 12, 5))//NL
    text = text//trim(' information (mean over the runs): trace '//es_text(s%info_trace, 12, 5)// &
                      '   det '//es_text(s%info_det, 12, 5))//NL
  end function mc_report

  function mc_json(title, job, s) result(text)
    character(len=*), intent(in) :: title, job
    type(mc_summary_t), intent(in) :: s
    character(len=:), allocatable :: text
    text = case_json(title, job, 0, '')
    text = text(1:len(text) - 1)//','//NL// &
           '"runs": '//itoa(s%runs)//', "failed": '//itoa(s%runs - s%ok)//', "seed": '// &
           itoa(s%seed)//', "input_file": '//json_string(trim(s%input_file))//', "samples": '// &
           itoa(s%samples)//','//NL// &
           '"parameters": '//strings(s%labels)//','//NL// &
           '"truth": '//numbers(s%truth)//','//NL// &
           '"start": '//numbers(s%start)//','//NL// &
           '"mean": '//numbers(s%mean)//','//NL// &
           '"sample_sigma": '//numbers(s%sample_sigma)//','//NL// &
           '"mean_cr_sigma": '//numbers(s%cr_sigma)//','//NL// &
           '"sample_cov_det": '//number(s%cov_det)//', "sample_cov_trace": '// &
           number(s%cov_trace)//','//NL// &
           '"mean_info_trace": '//number(s%info_trace)//', "mean_info_det": '// &
           number(s%info_det)//'}'
  end function mc_json

  !> The estimator and its band, then per parameter the last solve's
  !> estimate and sigma and when it converged; each equation's residual
  !> variance at the last solve.
  function online_report(o) result(text)
    type(online_summary_t), intent(in) :: o
    character(len=:), allocatable :: text
    character(len=256) :: buf
    integer :: k, m
    m = size(o%t)
    text = ' online estimation, '//trim(ESTIMATOR_WORDS(findloc(ONLINE_ESTIMATORS, o%estimator, 1)))// &
           ': '//itoa(o%samples)//' samples, '//o%settings//'; history to '//trim(o%out)//NL
    if (m == 0) return
    write (buf, '(1x,a16,3a15)') 'parameter       ', 'estimate', 'sigma', 'converged [s]'
    text = text//trim(buf)//NL
    do k = 1, size(o%names)
      write (buf, '(1x,a16)') o%names(k)
      text = text//trim(buf(1:17)//es_text(o%est(k, m), 15, 6)//es_text(o%sig(k, m), 15, 4)// &
                        es_text(o%converged(k), 15, 4))//NL
    end do
    text = text//' converged: from then on within 2 sigma of the last estimate'//NL
    text = text//trim(' '//trim(o%measure)//' (last):'//numbers_text(o%s2(:, m)))//NL
    if (o%per_sample >= 0.0_wp) text = text//' time per sample:'// &
      trim(es_text(1.0e6_wp*o%per_sample, 11, 3))//' us, the sampling interval'// &
      trim(es_text(1.0e3_wp*o%dt, 11, 3))//' ms (timed: this line differs from run to run)'//NL
  end function online_report

  function online_json(title, job, o) result(text)
    character(len=*), intent(in) :: title, job
    type(online_summary_t), intent(in) :: o
    character(len=:), allocatable :: text
    text = case_json(title, job, 0, '', o%samples, trim(o%out))
    text = text(1:len(text) - 1)//','//NL// &
           '"estimator": '//json_string(trim(o%estimator))//', "settings": '// &
           json_string(o%settings)//','//NL// &
           '"parameters": '//strings(o%names)//','//NL// &
           '"t": '//numbers(o%t)//','//NL// &
           '"estimates": '//matrix(transpose(o%est))//','//NL// &
           '"sigma": '//matrix(transpose(o%sig))//','//NL// &
           '"converged": '//numbers(o%converged)//','//NL// &
           '"measure": '//json_string(trim(o%measure))//', "measure_values": '// &
           matrix(transpose(o%s2))
    if (o%per_sample >= 0.0_wp) text = text//','//NL//'"seconds_per_sample": '// &
                                       number(o%per_sample)
    text = text//'}'
  end function online_json

  function numbers_text(v) result(text)
    real(wp), intent(in) :: v(:)
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 1, size(v)
      text = text//es_text(v(k), 12, 4)
    end do
  end function numbers_text

end module mlid_job_report
