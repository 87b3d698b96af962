!> The printed report of a fit (report Table 5.3 layout) and the JSON of a
!> case, built once as text: the job runner (mlid_run) gives these strings
!> to both front ends, which print and write them, so the two agree byte
!> for byte.
module mlid_report
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, stop_reason_text, fit_outcome, FIT_FAILED, STOP_DIVERGED
  use mlid_linalg, only: chol_inverse
  use mlid_options, only: NOPT, option_get
  use mlid_units, only: UNITLEN
  use mlid_text, only: itoa, es_text, fixed_text, utf8_head
  implicit none
  private
  public :: fit_summary_t, fit_report, fit_json, case_json, json_list, json_string, number, &
            numbers, strings, integers, matrix, &
            validation_report, validation_json, LABEL_WIDTH

  character, parameter :: NL = achar(10)
  integer, parameter :: LABEL_WIDTH = 16   !< the table's column of parameter labels
  !> the longest text of an unreached table value (its name, where it acts, the verdict)
  integer, parameter, public :: CELLLEN = 256

  !> What a report says of one fit (free parameters only, in the order of free).
  type :: fit_summary_t
    character(len=32), allocatable :: labels(:)
    real(wp), allocatable :: start(:), est(:), sig(:), sigc(:), cov(:, :), eigval(:), eigvec(:, :)
    real(wp), allocatable :: rhat(:, :), hist(:)
    real(wp) :: cost = 0.0_wp
    integer :: niter = 0, reason = 0, rank = 0
    integer :: lag = 0           !< lag of the coloured-residual correction (sigc)
    logical :: converged = .false.
    character(len=UNITLEN), allocatable :: units(:)  !< of each parameter (mlid_param_units)
    !> filter error with noise_criterion = 'innovations': the R it left (diagonal)
    real(wp), allocatable :: rnoise(:)
    !> noise_criterion = 'textbook': diag(KC) of the gain (the constraint <= 1)
    real(wp), allocatable :: kc(:)
    !> the outputs' names and units (the record's), under the noise's diagonal
    character(len=32), allocatable :: outputs(:)
    character(len=UNITLEN), allocatable :: output_units(:)
    !> the free table values no sample reaches, each 'NAME[i] (where it acts) is reached
    !> by no sample: not identifiable' (none: a model without tables, or all reached)
    character(len=CELLLEN), allocatable :: unreached(:)
    !> the labels of those values, in the same order
    character(len=32), allocatable :: unreached_labels(:)
  end type fit_summary_t

contains

  !> The report: how the iteration ended, the table of start, estimate and
  !> Cramer-Rao sigma, cost and noise, identifiability; every line ends in NL.
  !> A failed fit (fit_outcome) has none of these: failed_report says so.
  function fit_report(s, iopt, ropt, status, msg) result(text)
    type(fit_summary_t), intent(in) :: s
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    integer, intent(in) :: status      !< the fit's (mlid_kinds)
    character(len=*), intent(in) :: msg
    character(len=:), allocatable :: text, method, label
    character(len=512) :: buf
    logical :: oe, fd
    integer :: k

    if (fit_outcome(status, s%reason) == FIT_FAILED) then
      text = failed_report(s, iopt, ropt, msg)
      return
    end if
    method = method_text(iopt, ropt)
    oe = method(1:6) == 'output'
    fd = method(1:9) == 'frequency'
    write (buf, '(a,i0,a)') ' '//method//': ', s%niter, ' iterations, '// &
      trim(merge('converged    ', 'NOT converged', s%converged))//' ('// &
      trim(stop_reason_text(s%reason))//')'
    text = trim(buf)//NL
    if (s%reason == STOP_DIVERGED) text = text//' '//trim(msg)//NL   ! how (mlid_newton)
    if (iopt(10) > 0) then
      write (buf, '(a,i0,a,i0,a)') ' rank-deficient solution: rank ', s%rank, ' of ', &
        size(s%labels), ' (sigma from the same rank)'
      text = text//trim(buf)//NL
      text = text//not_estimated(s)
    end if
    write (buf, label_format('a15,a15,a13,a13')) 'parameter       ', 'unit      ', 'start', &
      'estimate', 'sigma', 'sigma col.'
    text = text//trim(buf)//NL
    do k = 1, size(s%labels)
      text = text//trim(label_unit(s, k)//es_text(s%start(k), 15, 6)//es_text(s%est(k), 15, 6)// &
             es_text(s%sig(k), 13, 4)//es_text(s%sigc(k), 13, 4))//NL
    end do
    write (buf, '(a,i0,a)') ' sigma col.: Cramer-Rao sigma corrected for coloured residuals ' // &
      '(residual autocorrelation to lag ', s%lag, ')'
    if (fd) buf = ' sigma col.: the same as sigma (no coloured-residual correction in the '// &
                  'frequency domain)'
    text = text//trim(buf)//NL
    ! output error estimates R; filter error reports the mean innovation covariance B
    ! (the textbook's filter error: R-hat, the innovations' mean square, is its R)
    buf = ' cost J = '//es_text(s%cost, 17, 10)//'   det '// &
          trim(merge('R', 'B', oe .or. fd .or. allocated(s%kc)))// &
          ' = '//es_text(det_r(s%rhat), 13, 6)
    if (fd) buf(index(buf, 'det R'):index(buf, 'det R') + 4) = 'det S'
    text = text//trim(buf)//NL
    if (.not. (oe .or. fd)) then
      buf = ' cost J'' = '//es_text(cost_prime(s%rhat), 17, 10)// &
            '   (1/2N) sum nu''nu, unweighted (report 5.1.6)'
      text = text//trim(buf)//NL
    end if
    if (fd) then      ! the residual spectrum S of the transformed outputs
      label = ' S diagonal:      '
    else
      label = ' '//trim(merge('R diagonal:      ', 'B diagonal (mean)', oe))
    end if
    text = text//label
    do k = 1, size(s%rhat, 1)
      text = text//' '//es_text(s%rhat(k, k), 10, 4)
    end do
    text = text//NL//noise_columns(s, len(label), fd)     ! under the values they name
    if (allocated(s%rnoise)) then
      text = text//' R diagonal (from the innovations)'
      do k = 1, size(s%rnoise)
        text = text//' '//es_text(s%rnoise(k), 10, 4)
      end do
      text = text//NL
    end if
    if (allocated(s%kc)) then
      text = text//' diag(KC) of the textbook gain (<= 1)'
      do k = 1, size(s%kc)
        text = text//' '//es_text(s%kc(k), 10, 4)
      end do
      text = text//NL
    end if
    text = text//identifiability(s%labels, s%eigval, s%eigvec, s%cov)
  end function fit_report

  !> The parameters a rank-deficient solution left wholly at their a priori
  !> values (sigma 0: they lie in the directions dropped), named: a table
  !> value no sample reaches is one (mlid_tables), named whatever rounding
  !> left in its sigma (its information is exactly zero); '' when there are
  !> none.
  function not_estimated(s) result(text)
    type(fit_summary_t), intent(in) :: s
    character(len=:), allocatable :: text
    integer :: k
    logical :: unreached
    text = ''
    do k = 1, size(s%labels)
      unreached = .false.
      if (allocated(s%unreached_labels)) unreached = any(s%unreached_labels == s%labels(k))
      if (s%sig(k) == 0.0_wp .or. unreached) text = text//' '//trim(s%labels(k))
    end do
    if (len(text) > 0) text = ' not identifiable, left at the a priori value (no information; '// &
                              'a table value: reached by no sample):'//text//NL
  end function not_estimated

  !> Under the noise's diagonal, whose output each value is and in what unit
  !> (the square of the output's; none for a frequency-domain S): a line
  !> each, their columns under the values; '' when the summary has no names.
  function noise_columns(s, width, fd) result(text)
    type(fit_summary_t), intent(in) :: s
    integer, intent(in) :: width        !< of the noise line's label, whose values these head
    logical, intent(in) :: fd           !< S of transforms: no unit line (it is (unit s)^2)
    character(len=:), allocatable :: text
    character(len=UNITLEN + 4) :: sq
    integer :: k
    text = ''
    if (.not. allocated(s%outputs)) return
    if (size(s%outputs) /= size(s%rhat, 1) .or. all(s%outputs == '')) return
    text = pad(' output:', width)
    do k = 1, size(s%outputs)
      text = text//' '//adjustr(column(s%outputs(k)))
    end do
    text = text//NL
    if (fd .or. .not. allocated(s%output_units)) return
    if (all(s%output_units == '')) return
    text = text//pad(' unit:', width)
    do k = 1, size(s%output_units)
      sq = s%output_units(k)
      if (scan(trim(sq), '/.') > 0) sq = '('//trim(sq)//')'
      if (len_trim(sq) > 0 .and. sq /= '-') sq = trim(sq)//'^2'
      text = text//' '//adjustr(column(sq))
    end do
    text = text//NL
  end function noise_columns

  !> label padded with blanks to width.
  function pad(label, width) result(c)
    character(len=*), intent(in) :: label
    integer, intent(in) :: width
    character(len=width) :: c
    c = label
  end function pad

  !> A name for a 10-character column: its first 10 bytes, at a character
  !> boundary.
  function column(name) result(c)
    character(len=*), intent(in) :: name
    character(len=10) :: c
    c = utf8_head(trim(name), 10)
  end function column

  !> The report of a failed fit: its first line says it failed, the table
  !> has only the start and the last values reached, and the last line is
  !> the error.  Whatever the failure left in sigma, cost, R and the
  !> information (never computed, or from a matrix with no inverse) is not
  !> printed.
  function failed_report(s, iopt, ropt, msg) result(text)
    type(fit_summary_t), intent(in) :: s
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    character(len=*), intent(in) :: msg
    character(len=:), allocatable :: text
    character(len=512) :: buf
    integer :: k

    write (buf, '(a,i0,a)') ' '//method_text(iopt, ropt)//': failed after ', s%niter, &
      ' iterations, no estimates'
    text = trim(buf)//NL
    write (buf, label_format('a15,a15')) 'parameter       ', 'unit      ', 'start', 'last value'
    text = text//trim(buf)//NL
    do k = 1, size(s%labels)
      text = text//trim(label_unit(s, k)//es_text(s%start(k), 15, 6)//es_text(s%est(k), 15, 6))//NL
    end do
    text = text//' last value: where the fit stopped, not an estimate (a failed fit has no '// &
           'sigma, correlations or cost)'//NL//' FAILED: '//trim(msg)//NL
  end function failed_report

  !> The estimator, as the report's first line names it.
  function method_text(iopt, ropt) result(text)
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    character(len=:), allocatable :: text
    character(len=160) :: buf
    if (any(option_get(iopt, ropt, 'method') == [character(len=32) :: 'frequency_output_error', &
                                                  'frequency_equation_error'])) then
      write (buf, '(a,g0.6,a,g0.6,a,a,a)') ', S '//trim(option_get(iopt, ropt, 'noise'))// &
        ', band ', ropt_value('f_min'), ' to ', ropt_value('f_max'), ' Hz, ', &
        trim(option_get(iopt, ropt, 'n_freq')), ' frequencies'
      text = trim(merge('frequency-domain output-error ML  ', 'frequency-domain equation error   ', &
                        option_get(iopt, ropt, 'method') == 'frequency_output_error'))//trim(buf)
    else if (option_get(iopt, ropt, 'method') == 'filter_error' .and. &
        option_get(iopt, ropt, 'filter_params') == 'gain') then
      text = 'filter-error ML, steady-state gain K and B as the parameters (eqs 4.19-4.21), B '// &
             trim(option_get(iopt, ropt, 'noise'))
    else if (option_get(iopt, ropt, 'method') == 'filter_error' .and. &
             option_get(iopt, ropt, 'noise_criterion') == 'textbook') then
      text = 'filter error as the textbook computes it (FVSysID ml_fem2): continuous Riccati '// &
             'gain with R dt, cost det R, diag(KC) <= 1'
    else if (option_get(iopt, ropt, 'method') == 'filter_error') then
      text = 'filter-error ML, '//trim(merge('steady-state gain', 'time-varying gain', &
             option_get(iopt, ropt, 'steady_state') == 'true'))//', '// &
             trim(merge('with gain partials   ', 'without gain partials', &
             option_get(iopt, ropt, 'partials') == 'true'))
    else
      text = 'output-error ML, R '//trim(option_get(iopt, ropt, 'noise'))
    end if

  contains

    real(wp) function ropt_value(name)
      character(len=*), intent(in) :: name
      character(len=32) :: word
      word = option_get(iopt, ropt, name)
      read (word, *) ropt_value
    end function ropt_value

  end function method_text

  !> What the information says about the parameters (report §4.5, §5.3.5):
  !> the eigenvalue spread of the normalised information, its weakest
  !> direction as a combination of named parameters, correlations above 0.9.
  function identifiability(labels, eigval, eigvec, cov) result(text)
    character(len=*), intent(in) :: labels(:)
    real(wp), intent(in) :: eigval(:), eigvec(:, :), cov(:, :)
    character(len=:), allocatable :: text, line
    character(len=16) :: num
    integer :: n, k, l, order(size(eigval)), shown
    real(wp) :: c, sgn

    text = ''
    n = size(eigval)
    if (n == 0) return
    text = ' normalised information: eigenvalues '//trim(fmt_e(eigval(1)))//' to '// &
           trim(fmt_e(eigval(n)))
    if (eigval(1) > 0.0_wp) text = text//', spread '//trim(fmt_e(eigval(n)/eigval(1)))
    ! components of the weakest direction, largest first
    order = [(k, k=1, n)]
    do k = 1, n
      do l = k + 1, n
        if (abs(eigvec(order(l), 1)) > abs(eigvec(order(k), 1))) order([k, l]) = order([l, k])
      end do
    end do
    line = ' weakest direction:'
    shown = 0
    sgn = sign(1.0_wp, eigvec(order(1), 1))   ! an eigenvector's sign is arbitrary: largest +
    do k = 1, n
      if (abs(eigvec(order(k), 1)) < 0.1_wp .or. shown == 5) exit
      write (num, '(sp,f5.2)') sgn*eigvec(order(k), 1)
      line = line//' '//trim(num)//' '//trim(labels(order(k)))
      shown = shown + 1
    end do
    text = text//NL//line//NL
    line = ' correlations above 0.9:'
    shown = 0
    do k = 1, n
      do l = k + 1, n
        if (.not. (cov(k, k) > 0.0_wp .and. cov(l, l) > 0.0_wp)) cycle
        c = cov(k, l)/sqrt(cov(k, k)*cov(l, l))
        if (abs(c) <= 0.9_wp) cycle
        write (num, '(sp,f5.2)') c
        line = line//trim(merge(' ', ',', shown == 0))//' '//trim(labels(k))//'/'// &
               trim(labels(l))//' '//trim(num)
        shown = shown + 1
      end do
    end do
    if (shown == 0) line = line//' none'
    text = text//line//NL
  end function identifiability

  function fmt_e(x) result(s)
    real(wp), intent(in) :: x
    character(len=16) :: s
    s = adjustl(es_text(x, 10, 3))
  end function fmt_e

  !> The report's J' (its §5.1.6): (1/2N) sum_j nu_j' nu_j, the unweighted
  !> mean square of the one-step prediction errors, from their mean square
  !> rhat = (1/N) sum nu nu' (the innovations' for filter error): half its trace.
  pure real(wp) function cost_prime(rhat)
    real(wp), intent(in) :: rhat(:, :)
    integer :: i
    cost_prime = 0.5_wp*sum([(rhat(i, i), i=1, size(rhat, 1))])
  end function cost_prime

  !> det R of the (positive-definite) noise or innovation covariance, from
  !> the Cholesky log-determinant; 0 if it is not positive definite.
  real(wp) function det_r(a)
    real(wp), intent(in) :: a(:, :)
    real(wp) :: ainv(size(a, 1), size(a, 1)), logdet
    integer :: info
    call chol_inverse(a, ainv, logdet, info)
    det_r = 0.0_wp
    if (info == 0) det_r = exp(logdet)
  end function det_r

  !> The lines of a validation (mlid_validate): the files predicted, then
  !> per output Theil's U, the rms prediction error in the unit the output
  !> is shown in (core = scale*shown, a difference has no offset) and
  !> rms/sigma.
  function validation_report(names, units, scale, holdout, theil, rms, ratio) result(text)
    character(len=*), intent(in) :: names(:), units(:)
    real(wp), intent(in) :: scale(:)
    integer, intent(in) :: holdout(:)
    real(wp), intent(in) :: theil(:), rms(:), ratio(:)
    character(len=:), allocatable :: text
    character(len=512) :: buf
    integer :: k

    text = ' validation: predicted file'//trim(merge('s', ' ', size(holdout) > 1))
    do k = 1, size(holdout)
      write (buf, '(1x,i0)') holdout(k)
      text = text//trim(buf)
    end do
    text = text//' (refitted there: only the initial state and output biases the '// &
           'identification fitted; every other parameter held at its estimate)'//NL
    write (buf, '(1x,a16,a12,a14,2x,a10,a12)') 'output          ', 'Theil U', 'rms error', &
      'unit      ', 'rms/sigma'
    text = text//trim(buf)//NL
    do k = 1, size(names)
      write (buf, '(1x,a16)') names(k)
      text = text//trim(buf(1:17)//fixed_text(theil(k), 12, 4)//es_text(rms(k)/scale(k), 14, 4)// &
             '  '//unit_cell(units(k))//fixed_text(ratio(k), 12, 3))//NL
    end do
    text = text//' Theil U: rms(y - yhat)/(rms(y) + rms(yhat)); rms error in the unit the '// &
           'output is shown in; sigma: the identification''s residual sigma'//NL
  contains
    !> a unit in its column of 10 (a longer one whole, then one blank)
    function unit_cell(unit) result(cell)
      character(len=*), intent(in) :: unit
      character(len=:), allocatable :: cell
      cell = trim(unit)
      if (len(cell) < 10) then
        cell = cell//repeat(' ', 10 - len(cell))
      else
        cell = cell//' '
      end if
    end function unit_cell
  end function validation_report

  !> The "validation" member of a validate case's JSON object.
  function validation_json(names, holdout, theil, rms, ratio) result(text)
    character(len=*), intent(in) :: names(:)
    integer, intent(in) :: holdout(:)
    real(wp), intent(in) :: theil(:), rms(:), ratio(:)
    character(len=:), allocatable :: text
    text = '"validation": {"holdout": '//integers(holdout)//', "outputs": '//strings(names)// &
           ','//NL//'"theil": '//numbers(theil)//', "rms": '//numbers(rms)// &
           ', "rms_over_sigma": '//numbers(ratio)//'}'
  end function validation_json

  !> The unit of free parameter k, '' if the fit has none.
  function unit_of(s, k) result(unit)
    type(fit_summary_t), intent(in) :: s
    integer, intent(in) :: k
    character(len=UNITLEN) :: unit
    unit = ''
    if (allocated(s%units)) unit = s%units(k)
  end function unit_of

  !> The JSON object of a fitted case; a failed one (fit_outcome) has its
  !> last values and null for every statistic of the fit.  "method" names
  !> the estimator (the option's word); "band" is the frequency-domain
  !> methods' f_min, f_max (Hz) and n_freq, null for the time domain.
  !> "unreached_cells" lists the free table values no sample reaches (the
  !> printed report names them among those not identifiable), [] when none.
  function fit_json(title, job, status, msg, s, iopt, ropt) result(text)
    character(len=*), intent(in) :: title, job, msg
    integer, intent(in) :: status
    type(fit_summary_t), intent(in) :: s
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    character(len=:), allocatable :: text
    integer :: k
    logical :: failed

    failed = fit_outcome(status, s%reason) == FIT_FAILED
    text = case_json(title, job, status, msg)
    text = text(1:len(text) - 1)//', "failed": '//trim(merge('true ', 'false', failed))//','//NL// &
           '"method": '//json_string(trim(option_get(iopt, ropt, 'method')))//', "band": '// &
           band_json(iopt, ropt)//','//NL// &
           '"parameters": '//strings(s%labels)//','//NL// &
           '"units": '//strings([(unit_of(s, k), k=1, size(s%labels))])//','//NL// &
           '"start": '//numbers(s%start)//','//NL
    if (failed) then
      text = text//'"estimate": null, "last_values": '//numbers(s%est)//','//NL// &
             '"sigma": null, "sigma_corrected": null, "colored_lag": null, "correlation": null,'// &
             NL//'"R": null, "det_R": null, "R_innovations": null, "cost": null, "cost_prime": null, '// &
             '"cost_history": null,'// &
             NL// &
             '"iterations": '//itoa(s%niter)//', "converged": false, "rank": null,'//NL// &
             '"unreached_cells": null'
    else
      text = text//'"estimate": '//numbers(s%est)//','//NL//'"sigma": '//numbers(s%sig)//','//NL// &
             '"sigma_corrected": '//numbers(s%sigc)//', "colored_lag": '//itoa(s%lag)// &
             ','//NL// &
             '"correlation": '//matrix(correlation(s%cov))//','//NL// &
             '"R": '//matrix(s%rhat)//','//NL//'"det_R": '//number(det_r(s%rhat))// &
             ', "R_innovations": '//r_innovations()// &
             ', "cost": '//number(s%cost)//', "cost_prime": '//number(cost_prime(s%rhat))// &
             ','//NL//'"cost_history": '//numbers(s%hist)//','//NL// &
             '"iterations": '//itoa(s%niter)//', "converged": '// &
             trim(merge('true ', 'false', s%converged))//', "rank": '//itoa(s%rank)// &
             ','//NL//'"unreached_cells": '//unreached_list()
    end if
    text = text//', "reason": '//json_string(trim(stop_reason_text(s%reason)))//'}'

  contains

    function r_innovations() result(v)
      character(len=:), allocatable :: v
      v = 'null'
      if (allocated(s%rnoise)) v = numbers(s%rnoise)
    end function r_innovations

    !> The table values no sample reaches, [] when none (or no tables).
    function unreached_list() result(v)
      character(len=:), allocatable :: v
      v = '[]'
      if (allocated(s%unreached)) v = strings(s%unreached)
    end function unreached_list

  end function fit_json

  !> The band of a frequency-domain fit as JSON, {"f_min": .., "f_max": ..,
  !> "n_freq": ..}; null for a time-domain one.
  function band_json(iopt, ropt) result(text)
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    character(len=:), allocatable :: text
    real(wp) :: f(2)
    character(len=32) :: word
    text = 'null'
    if (all(option_get(iopt, ropt, 'method') /= [character(len=32) :: 'frequency_output_error', &
                                                  'frequency_equation_error'])) return
    word = option_get(iopt, ropt, 'f_min')
    read (word, *) f(1)
    word = option_get(iopt, ropt, 'f_max')
    read (word, *) f(2)
    text = '{"f_min": '//number(f(1))//', "f_max": '//number(f(2))//', "n_freq": '// &
           trim(option_get(iopt, ropt, 'n_freq'))//'}'
  end function band_json

  !> The JSON object of a case without a fit: title, job, status, message
  !> and, for a simulate case, the samples written and where.
  function case_json(title, job, status, msg, samples, out) result(text)
    character(len=*), intent(in) :: title, job, msg
    integer, intent(in) :: status
    integer, intent(in), optional :: samples
    character(len=*), intent(in), optional :: out
    character(len=:), allocatable :: text
    character(len=16) :: buf
    write (buf, '(i0)') status
    text = '{"title": '//json_string(title)//', "job": '//json_string(job)//','//NL// &
           '"status": '//trim(buf)//', "message": '//json_string(msg)
    if (present(samples) .and. present(out)) then
      write (buf, '(i0)') samples
      text = text//','//NL//'"samples": '//trim(buf)//', "out": '//json_string(out)
    end if
    text = text//'}'
  end function case_json

  !> The --json file: the objects of a deck's cases as one list.
  function json_list(objects, n) result(text)
    character(len=*), intent(in) :: objects
    integer, intent(in) :: n
    character(len=:), allocatable :: text
    text = '['//NL//objects
    if (n > 0) text = text//NL
    text = text//']'//NL
  end function json_list

  !> A JSON string: quotes, backslashes and control characters escaped; a
  !> byte that does not start a whole UTF-8 character becomes U+FFFD, so a
  !> message cut mid-character or a latin-1 title still makes valid JSON.
  function json_string(s) result(q)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: q
    character(len=6) :: esc
    integer :: k, n, b, last
    q = '"'
    k = 1
    last = len_trim(s)
    do while (k <= last)
      b = iachar(s(k:k))
      n = utf8_length(s(k:last))
      if (s(k:k) == '"' .or. s(k:k) == '\') then
        q = q//'\'//s(k:k)
      else if (b < 32 .or. b == 127) then
        write (esc, '(a,z4.4)') '\u', b
        q = q//esc
      else if (n == 0) then
        q = q//'\ufffd'
      else
        q = q//s(k:k + n - 1)
        k = k + n
        cycle
      end if
      k = k + 1
    end do
    q = q//'"'
  end function json_string

  !> Bytes of the UTF-8 character at the start of s; 0 if none starts there.
  integer function utf8_length(s)
    character(len=*), intent(in) :: s
    integer :: b, n, j
    b = iachar(s(1:1))
    if (b < 128) then
      n = 1
    else if (b >= 194 .and. b <= 223) then
      n = 2
    else if (b >= 224 .and. b <= 239) then
      n = 3
    else if (b >= 240 .and. b <= 244) then
      n = 4
    else
      n = 0
    end if
    utf8_length = 0
    if (n == 0 .or. n > len(s)) return
    do j = 2, n
      if (iachar(s(j:j)) < 128 .or. iachar(s(j:j)) > 191) return
    end do
    utf8_length = n
  end function utf8_length

  function correlation(cov) result(c)
    real(wp), intent(in) :: cov(:, :)
    real(wp) :: c(size(cov, 1), size(cov, 2))
    integer :: k, l
    do l = 1, size(cov, 2)
      do k = 1, size(cov, 1)
        c(k, l) = 0.0_wp
        if (cov(k, k) > 0.0_wp .and. cov(l, l) > 0.0_wp) &
          c(k, l) = cov(k, l)/sqrt(cov(k, k)*cov(l, l))
      end do
    end do
  end function correlation

  function matrix(a) result(text)
    real(wp), intent(in) :: a(:, :)
    character(len=:), allocatable :: text
    integer :: k
    text = '['
    do k = 1, size(a, 1)
      text = text//numbers(a(k, :))
      if (k < size(a, 1)) text = text//', '
    end do
    text = text//']'
  end function matrix

  function number(x) result(s)
    real(wp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=32) :: buf
    if (ieee_is_finite(x)) then
      write (buf, '(es24.16e3)') x
      s = trim(adjustl(buf))
    else
      s = 'null'
    end if
  end function number

  !> A JSON list of strings: ["a", "b"] (each trimmed).
  function strings(names) result(s)
    character(len=*), intent(in) :: names(:)
    character(len=:), allocatable :: s
    integer :: k
    s = '['
    do k = 1, size(names)
      s = s//json_string(trim(names(k)))
      if (k < size(names)) s = s//', '
    end do
    s = s//']'
  end function strings

  !> A JSON list of integers.
  function integers(n) result(s)
    integer, intent(in) :: n(:)
    character(len=:), allocatable :: s
    integer :: k
    s = '['
    do k = 1, size(n)
      s = s//itoa(n(k))
      if (k < size(n)) s = s//', '
    end do
    s = s//']'
  end function integers

  function numbers(x) result(s)
    real(wp), intent(in) :: x(:)
    character(len=:), allocatable :: s
    integer :: k
    s = '['
    do k = 1, size(x)
      s = s//number(x(k))
      if (k < size(x)) s = s//', '
    end do
    s = s//']'
  end function numbers

  !> The start of row k of the table of parameters: its label and unit.
  function label_unit(s, k) result(text)
    type(fit_summary_t), intent(in) :: s
    integer, intent(in) :: k
    character(len=LABEL_WIDTH + 12) :: text
    write (text, label_format('')) s%labels(k), unit_of(s, k)
  end function label_unit

  !> A row of the table of parameters: label, unit, then rest.
  function label_format(rest) result(f)
    character(len=*), intent(in) :: rest
    character(len=:), allocatable :: f
    f = '(1x,a'//itoa(LABEL_WIDTH)//',1x,a10'
    if (len(rest) > 0) f = f//','//rest
    f = f//')'
  end function label_format

end module mlid_report
