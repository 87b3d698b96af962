!> Estimator and integration options, and their flat encoding.
!>
!> The flat interface carries options as iopt(16) and ropt(16) so that f2py
!> and the deck reader need no derived types; this module is the one place
!> that knows the layout.
module mlid_options
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: to_lower, joined
  implicit none
  private
  public :: options_t, options_from_flat, options_to_flat, NOPT
  public :: NOPTION, OPTION_NAMES, option_kind, option_words, option_set, option_get, options_text
  public :: METHOD_OUTPUT_ERROR, METHOD_FILTER_ERROR, METHOD_FREQ_OE, METHOD_FREQ_EE, &
            frequency_method

  integer, parameter :: NOPT = 16  !< length of iopt and ropt
  !> Limits checked before any work starts: beyond them a run would hang or
  !> allocate without bound, and no real case comes near them.
  integer, parameter, public :: MAX_ITER_LIMIT = 10000, HALVINGS_LIMIT = 60, SUBSTEPS_LIMIT = 1000, &
                                NFREQ_LIMIT = 100000
  integer, parameter :: DEFAULT_N_FREQ = 50   !< frequencies in the band unless n_freq says
  !> The codes of option method, in the order of its choices: output error
  !> (report §4.4), filter error (§4.1, §4.3), and the frequency-domain
  !> methods (mlid_frequency).
  integer, parameter :: METHOD_OUTPUT_ERROR = 0, METHOD_FILTER_ERROR = 1, METHOD_FREQ_OE = 2, &
                        METHOD_FREQ_EE = 3

  !> The options by name, for Python and any other caller that should not
  !> know the flat layout: option k lives in iopt(k) for k <= NIOPT, else in
  !> ropt(k - NIOPT).  Choices are listed in the order of their codes 0, 1.
  integer, parameter :: NOPTION = 23, NIOPT = 16
  character(len=16), parameter :: OPTION_NAMES(NOPTION) = [character(len=16) :: &
    'max_iter', 'halvings', 'noise', 'input_hold', 'substeps', 'method', 'partials', &
    'steady_state', 'startup', 'rank_min', 'rank_max', 'rank_rule', 'process_noise', &
    'noise_criterion', 'filter_params', 'n_freq', 'tol_cost', 'tol_step', 'tol_grad', 'rcond', &
    'prior_decay', 'f_min', 'f_max']
  character(len=80), parameter :: OPTION_CHOICES(NOPTION) = [character(len=80) :: &
    '', '', 'diagonal full', 'linear zoh', '', &
    'output_error filter_error frequency_output_error frequency_equation_error', 'false true', &
    'false true', 'none equation_error', '', '', 'iteration staged', &
    'held continuous continuous_sd', 'exact innovations textbook', 'noise gain', '', '', '', '', '', &
    '', '', '']

  type :: options_t
    integer :: max_iter = 30      !< iopt(1): Newton iterations at most
    integer :: halvings = 5       !< iopt(2): step halvings when the cost rises
    logical :: full_r = .false.   !< iopt(3): 0 diagonal R, 1 full R
    logical :: hold = .false.     !< iopt(4): 0 input linear between samples, 1 zero-order hold
    integer :: substeps = 1       !< iopt(5): RK4 steps per sample interval
    !> iopt(6): 0 output error, 1 filter error (Kalman filter), 2 frequency-domain output
    !> error, 3 frequency-domain equation error (mlid_frequency)
    integer :: method = 0
    logical :: partials = .true.  !< iopt(7): filter error with covariance/gain partials (eqs 4.32-4.34)
    logical :: steady = .false.   !< iopt(8): filter error with the steady-state gain
    integer :: startup = 0        !< iopt(9): 0 from the given values, 1 equation-error start-up
    integer :: rank_min = 0       !< iopt(10): rank-deficient search from this rank (0: full rank only)
    integer :: rank_max = 0       !< iopt(11): ... up to this rank (0: full rank)
    integer :: rank_rule = 0      !< iopt(12): 0 best rank each iteration (report §4.6 blocks 7-10),
                                  !<   1 staged: converge at each rank, one more direction at a time
    !> iopt(13): what the q parameters are (mlid_filter's lti_setup):
    !>   0 held: variances of process noise held over each sample interval,
    !>   1 continuous: spectral densities of continuous white noise,
    !>   2 continuous_sd: standard deviations of continuous white noise (density q^2)
    integer :: process_noise = 0
    !> iopt(14): how filter error estimates the measurement noise R (mlid_newton):
    !>   0 exact: r are parameters like any other (free or fixed),
    !>   1 innovations: r from the innovations after each Newton step on the
    !>     others, R = mean squared innovations - C P C', at least a floor
    !>   2 textbook: FVSysID's ml_fem2 (mlid_textbook_gain, mlid_likelihood,
    !>     mlid_newton): the gain from the continuous Riccati equation with R dt
    !>     as the measurement density, cost det R, R the innovations' mean
    !>     square after each step, F compensated, diag(KC) <= 1
    integer :: noise_criterion = 0
    !> iopt(15): what filter error estimates besides the system parameters:
    !>   0 noise: the noise statistics q, r, S (eq. 4.17 with eqs 4.8-4.18),
    !>   1 gain: the steady-state gain K (block stab, nx x ny) and B (report
    !>     eqs 4.19-4.21): the predictor x(j|j) = x(j|j-1) + K nu(j) with K
    !>     a parameter, B = (1/N) sum nu nu' (eq. 4.20) as output error's R
    integer :: filter_params = 0
    !> iopt(16): frequencies of the band of the frequency-domain methods, evenly
    !> spaced from f_min to f_max (both included)
    integer :: n_freq = DEFAULT_N_FREQ
    !> ropt(1): |dJ| <= tol_cost*max(1,|J|); with noise_criterion = 'textbook'
    !> the relative change of det R a step makes (ml_fem2's tolR, 1e-4 there)
    real(wp) :: tol_cost = 1.0e-8_wp
    real(wp) :: tol_step = 1.0e-8_wp  !< ropt(2): |dtheta| <= tol_step*|theta|
    real(wp) :: tol_grad = 1.0e-4_wp  !< ropt(3): sqrt(g' M^-1 g) (step in Cramer-Rao sigmas)
    real(wp) :: rcond = 1.0e-10_wp    !< ropt(4): eigenvalues of M below rcond*max are singular
    real(wp) :: prior_decay = 1.0_wp  !< ropt(5): a priori weights times this each iteration (§4.5.2)
    !> ropt(6), ropt(7): the band of the frequency-domain methods, Hz (0: not given)
    real(wp) :: f_min = 0.0_wp, f_max = 0.0_wp
  end type options_t

contains

  !> Encode options in the flat layout (unused slots are zero).
  subroutine options_to_flat(opt, iopt, ropt)
    type(options_t), intent(in) :: opt
    integer, intent(out) :: iopt(NOPT)
    real(wp), intent(out) :: ropt(NOPT)
    iopt = 0
    ropt = 0.0_wp
    iopt(1) = opt%max_iter
    iopt(2) = opt%halvings
    iopt(3) = merge(1, 0, opt%full_r)
    iopt(4) = merge(1, 0, opt%hold)
    iopt(5) = opt%substeps
    iopt(6) = opt%method
    iopt(7) = merge(1, 0, opt%partials)
    iopt(8) = merge(1, 0, opt%steady)
    iopt(9) = opt%startup
    iopt(10) = opt%rank_min
    iopt(11) = opt%rank_max
    iopt(12) = opt%rank_rule
    iopt(13) = opt%process_noise
    iopt(14) = opt%noise_criterion
    iopt(15) = opt%filter_params
    iopt(16) = opt%n_freq
    ropt(1) = opt%tol_cost
    ropt(2) = opt%tol_step
    ropt(3) = opt%tol_grad
    ropt(4) = opt%rcond
    ropt(5) = opt%prior_decay
    ropt(6) = opt%f_min
    ropt(7) = opt%f_max
  end subroutine options_to_flat

  !> Decode and check the flat options.  Zero or negative entries where a
  !> positive value is required are errors; the Python layer and the deck
  !> reader fill in the defaults above.
  subroutine options_from_flat(iopt, ropt, opt, status, msg)
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    type(options_t), intent(out) :: opt
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg

    status = MLID_ERR_INPUT
    opt%max_iter = iopt(1)
    opt%halvings = iopt(2)
    opt%full_r = iopt(3) == 1
    opt%hold = iopt(4) == 1
    opt%substeps = iopt(5)
    opt%method = iopt(6)
    opt%partials = iopt(7) == 1
    opt%steady = iopt(8) == 1
    opt%startup = iopt(9)
    opt%rank_min = iopt(10)
    opt%rank_max = iopt(11)
    opt%rank_rule = iopt(12)
    opt%process_noise = iopt(13)
    opt%noise_criterion = iopt(14)
    opt%filter_params = iopt(15)
    opt%n_freq = iopt(16)
    opt%tol_cost = ropt(1)
    opt%tol_step = ropt(2)
    opt%tol_grad = ropt(3)
    opt%rcond = ropt(4)
    opt%prior_decay = ropt(5)
    opt%f_min = ropt(6)
    opt%f_max = ropt(7)
    if (opt%max_iter < 0 .or. opt%max_iter > MAX_ITER_LIMIT) then
      write (msg, '(a,i0,a,i0)') 'max_iter must lie in 0 to ', MAX_ITER_LIMIT, ', got ', opt%max_iter
    else if (opt%halvings < 0 .or. opt%halvings > HALVINGS_LIMIT) then
      write (msg, '(a,i0,a,i0)') 'halvings must lie in 0 to ', HALVINGS_LIMIT, ', got ', opt%halvings
    else if (iopt(3) /= 0 .and. iopt(3) /= 1) then
      write (msg, '(a,i0)') 'noise code must be 0 (diagonal) or 1 (full), got ', iopt(3)
    else if (iopt(4) /= 0 .and. iopt(4) /= 1) then
      write (msg, '(a,i0)') 'input hold code must be 0 (linear) or 1 (zero-order), got ', iopt(4)
    else if (opt%method < 0 .or. opt%method > METHOD_FREQ_EE) then
      write (msg, '(a,i0)') 'method code must be 0 (output error), 1 (filter error), 2 '// &
        '(frequency output error) or 3 (frequency equation error), got ', iopt(6)
    else if (any(iopt(7:9) /= 0 .and. iopt(7:9) /= 1)) then
      msg = 'partials, steady and startup flags must be 0 or 1'
    else if (opt%substeps < 1 .or. opt%substeps > SUBSTEPS_LIMIT) then
      write (msg, '(a,i0,a,i0)') 'substeps must lie in 1 to ', SUBSTEPS_LIMIT, ', got ', opt%substeps
    else if (.not. all([opt%tol_cost, opt%tol_step, opt%tol_grad] >= 0.0_wp .and. &
                       ieee_is_finite([opt%tol_cost, opt%tol_step, opt%tol_grad]))) then
      msg = 'tolerances tol_cost, tol_step, tol_grad must be finite and >= 0'
    else if (.not. (opt%rcond > 0.0_wp .and. opt%rcond < 1.0_wp)) then
      msg = 'rcond must lie in (0, 1)'
    else if (opt%rank_min < 0 .or. opt%rank_max < 0) then
      msg = 'rank_min and rank_max must be >= 0'
    else if (opt%rank_rule /= 0 .and. opt%rank_rule /= 1) then
      write (msg, '(a,i0)') 'rank rule code must be 0 (each iteration) or 1 (staged), got ', iopt(12)
    else if (opt%process_noise < 0 .or. opt%process_noise > 2) then
      write (msg, '(a,i0)') 'process noise code must be 0 (held), 1 (continuous) or 2 '// &
        '(continuous_sd), got ', iopt(13)
    else if (opt%noise_criterion < 0 .or. opt%noise_criterion > 2) then
      write (msg, '(a,i0)') 'noise criterion code must be 0 (exact), 1 (innovations) or 2 '// &
        '(textbook), got ', iopt(14)
    else if (opt%noise_criterion >= 1 .and. opt%method /= METHOD_FILTER_ERROR) then
      msg = 'noise_criterion = '''//trim(choice_word(OPTION_CHOICES(14), opt%noise_criterion))// &
            ''' is for filter error (method = ''filter_error''): output error estimates R '// &
            'from the residuals anyway'
    else if (opt%noise_criterion == 2 .and. .not. opt%steady) then
      msg = 'noise_criterion = ''textbook'' is the textbook''s steady-state filter: set '// &
            'steady_state = true'
    else if (opt%noise_criterion == 2 .and. opt%process_noise == 0) then
      msg = 'noise_criterion = ''textbook'' takes continuous process noise: process_noise = '// &
            '''continuous_sd'' (q the textbook''s F) or ''continuous'''
    else if (opt%noise_criterion == 2 .and. opt%full_r) then
      msg = 'noise_criterion = ''textbook'' estimates a diagonal R: noise = ''diagonal'''
    else if (opt%filter_params < 0 .or. opt%filter_params > 1) then
      write (msg, '(a,i0)') 'filter parameters code must be 0 (noise) or 1 (gain), got ', iopt(15)
    else if (opt%filter_params == 1 .and. opt%method /= METHOD_FILTER_ERROR) then
      msg = 'filter_params = ''gain'' is for filter error (method = ''filter_error'')'
    else if (opt%filter_params == 1 .and. opt%noise_criterion >= 1) then
      msg = 'filter_params = ''gain'' estimates B from the innovations (eq. 4.20), not R: '// &
            'leave noise_criterion = ''exact'''
    else if (opt%rank_max > 0 .and. opt%rank_max < opt%rank_min) then
      write (msg, '(a,i0,a,i0)') 'rank_max = ', opt%rank_max, ' is below rank_min = ', opt%rank_min
    else if (.not. (opt%prior_decay > 0.0_wp .and. opt%prior_decay <= 1.0_wp)) then
      msg = 'prior_decay must lie in (0, 1]'
    else
      call band_check(opt, msg)
      if (len_trim(msg) == 0) status = MLID_OK
    end if
  end subroutine options_from_flat

  !> The frequency-domain methods' options: the band 0 < f_min < f_max and
  !> 2 <= n_freq (the Nyquist limit needs the record: mlid_frequency), no
  !> equation-error start-up; the band given to a time-domain method is an
  !> error, not ignored.  msg = '' when they are fine.
  subroutine band_check(opt, msg)
    type(options_t), intent(in) :: opt
    character(len=*), intent(out) :: msg
    msg = ''
    if (.not. frequency_method(opt)) then
      if (opt%f_min /= 0.0_wp .or. opt%f_max /= 0.0_wp .or. opt%n_freq /= DEFAULT_N_FREQ) &
        msg = 'f_min, f_max and n_freq are the band '// &
        'of the frequency-domain methods (method = ''frequency_output_error'' or '// &
        '''frequency_equation_error'')'
    else if (.not. (opt%f_min > 0.0_wp .and. opt%f_max > opt%f_min .and. &
                    ieee_is_finite(opt%f_max))) then
      msg = 'the frequency-domain methods need the band 0 < f_min < f_max (Hz)'
    else if (opt%n_freq < 2 .or. opt%n_freq > NFREQ_LIMIT) then
      write (msg, '(a,i0,a,i0)') 'n_freq must lie in 2 to ', NFREQ_LIMIT, ', got ', opt%n_freq
    else if (opt%startup /= 0) then
      msg = 'startup = ''equation_error'' is a time-domain start: the frequency-domain '// &
            'methods start from the given values (frequency_equation_error needs no start)'
    else if (opt%hold) then
      msg = 'input_hold = ''zoh'' is not for the frequency-domain methods: their transform '// &
            'takes straight lines between the samples (mlid_fourier)'
    end if
  end subroutine band_check

  !> Whether opt's method works on the Fourier transform of the record.
  pure logical function frequency_method(opt)
    type(options_t), intent(in) :: opt
    frequency_method = opt%method == METHOD_FREQ_OE .or. opt%method == METHOD_FREQ_EE
  end function frequency_method

  !> 'int', 'real', 'bool' or 'choice' (with the words of OPTION_CHOICES);
  !> '' for a name that is no option.
  function option_kind(name) result(kind)
    character(len=*), intent(in) :: name
    character(len=6) :: kind
    kind = kind_at(option_index(name))
  end function option_kind

  !> The words a choice option takes, blank-separated in the order of their
  !> codes ('false true' for a logical one; '' for a number or no option).
  function option_words(name) result(words)
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: words
    integer :: k
    words = ''
    k = option_index(name)
    if (k >= 1 .and. k <= NOPTION) words = trim(OPTION_CHOICES(k))
  end function option_words

  !> The kind of option k (its place in OPTION_NAMES; '' for none).
  function kind_at(k) result(kind)
    integer, intent(in) :: k
    character(len=6) :: kind
    kind = ''
    if (k < 1 .or. k > NOPTION) return
    if (k > NIOPT) then
      kind = 'real'
    else if (OPTION_CHOICES(k) == 'false true') then
      kind = 'bool'
    else if (len_trim(OPTION_CHOICES(k)) > 0) then
      kind = 'choice'
    else
      kind = 'int'
    end if
  end function kind_at

  !> Set one option in the flat arrays from its text ('20', 'full', 'true',
  !> '1e-8'); the value's range is checked later by options_from_flat.
  subroutine option_set(iopt, ropt, name, text, status, msg)
    integer, intent(inout) :: iopt(NOPT)
    real(wp), intent(inout) :: ropt(NOPT)
    character(len=*), intent(in) :: name, text
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, code, ios
    real(wp) :: x

    status = MLID_ERR_INPUT
    k = option_index(name)
    if (k == 0) then
      msg = 'unknown option '''//trim(name)//'''; known: '//joined(OPTION_NAMES)
      return
    end if
    select case (option_kind(name))
    case ('real')
      read (text, *, iostat=ios) x
      if (ios /= 0 .or. .not. ieee_is_finite(x) .or. index(text, '*') > 0) then
        msg = 'option '//trim(name)//' takes a finite number, got '''//trim(text)//''''
        return
      end if
      ropt(k - NIOPT) = x
    case ('int')
      read (text, *, iostat=ios) x
      if (ios /= 0 .or. .not. (abs(x) <= real(huge(1), wp)) .or. x /= aint(x) .or. &
          index(text, '*') > 0) then
        msg = 'option '//trim(name)//' takes a whole number within +-2147483647, got '''// &
              trim(text)//''''
        return
      end if
      iopt(k) = nint(x)
    case default
      code = choice_code(OPTION_CHOICES(k), text)
      if (code < 0) then
        msg = 'option '//trim(name)//' must be one of '//trim(OPTION_CHOICES(k))//', got '''// &
              trim(text)//''''
        return
      end if
      iopt(k) = code
    end select
    status = MLID_OK
    msg = ''
  end subroutine option_set

  !> One option's value as text, in the form option_set takes.
  function option_get(iopt, ropt, name) result(text)
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    character(len=*), intent(in) :: name
    character(len=32) :: text
    text = option_text(iopt, ropt, option_index(name))
  end function option_get

  !> Option k's value as text (option_get; k its place in OPTION_NAMES).
  function option_text(iopt, ropt, k) result(text)
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    integer, intent(in) :: k
    character(len=32) :: text
    text = ''
    if (k < 1 .or. k > NOPTION) return
    select case (kind_at(k))
    case ('real')
      write (text, '(es24.16e3)') ropt(k - NIOPT)
      text = adjustl(text)
    case ('int')
      write (text, '(i0)') iopt(k)
    case ('bool', 'choice')
      text = choice_word(OPTION_CHOICES(k), iopt(k))
    end select
  end function option_text

  !> Every option by name, one a line in the table's order: 'name value',
  !> the value as option_get gives it.
  function options_text(iopt, ropt) result(text)
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 1, NOPTION
      text = text//trim(OPTION_NAMES(k))//' '//trim(option_text(iopt, ropt, k))//achar(10)
    end do
  end function options_text

  integer function option_index(name)
    character(len=*), intent(in) :: name
    integer :: k
    option_index = 0
    do k = 1, NOPTION
      if (to_lower(adjustl(name)) == OPTION_NAMES(k)) option_index = k
    end do
  end function option_index

  !> The code (0, 1, ...) of a word among the choices; -1 if absent.  A
  !> bool also takes 1/0 and Fortran's .true./.false., t/f.
  integer function choice_code(choices, word)
    character(len=*), intent(in) :: choices, word
    character(len=len(word)) :: w
    integer :: k
    w = to_lower(adjustl(word))
    if (choices == 'false true') then
      select case (w)
      case ('true', '.true.', 't', '1')
        choice_code = 1
        return
      case ('false', '.false.', 'f', '0')
        choice_code = 0
        return
      end select
    end if
    do k = 0, 9
      choice_code = k
      if (len_trim(w) > 0 .and. choice_word(choices, k) == w) return
    end do
    choice_code = -1
  end function choice_code

  !> Word number code (from 0) of a blank-separated list; '' past its end.
  function choice_word(choices, code) result(word)
    character(len=*), intent(in) :: choices
    integer, intent(in) :: code
    character(len=32) :: word
    integer :: k, p
    character(len=len(choices)) :: rest
    rest = adjustl(choices)
    word = ''
    do k = 0, code
      p = index(rest, ' ')
      word = rest(1:p - 1)
      rest = adjustl(rest(p:))
    end do
    if (code < 0 .or. len_trim(word) == 0) word = ''
  end function choice_word

end module mlid_options
