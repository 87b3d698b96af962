!> "Which input to fly": candidate inputs for a linear model's design, each
!> scaled to a common energy int u'u dt or a common peak |u|, ranked by the
!> information they give the unknowns (D-optimal, det M, or tr M).
!>
!> The candidates are held over the n equal cells of [0, T] the design's
!> input has: 'optimal' (the design's own input, given by the caller), and
!> from the signal library (mlid_inputs, mlid_signals) 'doublet', '3211',
!> 'multisine', 'sweep' (linear), 'log_sweep' and 'prbs', each cell taking
!> the signal's value at its start.  With several inputs the multisine
!> drives them all at once (its inputs are mutually orthogonal); every
!> other shape drives them one after the other, input j in the j-th of nu
!> equal windows of T.  Settings the caller leaves at 0 come from the model:
!> w_max, the largest |eigenvalue| of F, gives the band [1/T, w_max/pi] Hz
!> (at least 2 nu harmonics of 1/T, below 0.4/cell) of the multisine and
!> the sweeps, the base pulse 2.33/w_max of the doublet and the 3211 (the
!> doublet's energy spectrum peaks at w dt = 2.33, tan(w dt/2) = w dt, so
!> at the fastest mode); a base pulse, given or not, is shortened to fit
!> its window and rounded to cells; the PRBS clock
!> 0.44/f_max (its spectrum's half power at f_max), its order the least
!> whose period fills the window.
!>
!> For each candidate: the information M of the unknowns (input_information:
!> with process noise the steady-state filter's sensitivities, eq. 7.84),
!> its det, trace and Cramer-Rao sigma (information_summary), and the peak
!> and rms of every state and output H x of the model over [0, T] (the state
!> limits of report 7.6; input_response, four exact samples a cell).
module mlid_input_ranking
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_INTERNAL
  use mlid_text, only: to_lower, itoa, es_text, choices
  use mlid_design, only: design_t, input_information, information_summary, input_response, &
                         simpson_weights
  use mlid_linalg, only: general_eig
  use mlid_memory, only: no_memory
  use mlid_inputs, only: input_signal
  use mlid_signals, only: multisine_band, multisine, sweep, prbs, MULTISINE_ITERATIONS
  implicit none
  private
  public :: ranking_options_t, ranking_t, rank_candidates, check_ranking_options, &
            CANDIDATE_NAMES, COMPARE_NAMES, RANK_BY_NAMES

  character(len=9), parameter :: CANDIDATE_NAMES(7) = [character(len=9) :: 'optimal', &
    'doublet', '3211', 'multisine', 'sweep', 'log_sweep', 'prbs']
  character(len=6), parameter :: COMPARE_NAMES(2) = [character(len=6) :: 'energy', 'peak']
  character(len=5), parameter :: RANK_BY_NAMES(2) = [character(len=5) :: 'det', 'trace']
  !> the doublet's energy spectrum peaks at w dt = 2.33 (tan(w dt/2) = w dt)
  real(wp), parameter :: DOUBLET_PEAK = 2.3311_wp
  real(wp), parameter :: PI = 3.14159265358979323846264338327950288_wp
  !> exact samples per cell of the responses (even: Simpson's rule)
  integer, parameter :: NS = 4

  !> What to compare: the candidates, at equal 'energy' or 'peak', ranked by
  !> 'det' or 'trace'; the band [Hz] and base pulse [s], 0 for the model's.
  type :: ranking_options_t
    character(len=16), allocatable :: names(:)
    character(len=16) :: compare = 'energy', rank_by = 'det'
    real(wp) :: f_min = 0.0_wp, f_max = 0.0_wp, pulse_width = 0.0_wp
  end type ranking_options_t

  !> The candidates in the order given; order(r) is the one ranked r.
  type :: ranking_t
    character(len=16), allocatable :: names(:)
    character(len=48), allocatable :: detail(:)      !< each signal's settings, in words
    character(len=16) :: compare = '', rank_by = ''
    real(wp) :: level = 0.0_wp                       !< the common energy or peak
    integer, allocatable :: order(:)
    !> u(cells nu, candidate) as scaled; their energies and peaks
    real(wp), allocatable :: u(:, :), energy(:), peak(:)
    real(wp), allocatable :: mm(:, :, :), det(:), trace(:), sigma(:, :)
    !> peak and rms of each state (x) and output (y), a column per candidate
    real(wp), allocatable :: x_peak(:, :), x_rms(:, :), y_peak(:, :), y_rms(:, :)
  end type ranking_t


contains

  !> The options' names and numbers, as a deck or a call gave them (msg
  !> names the entry at fault).  nyquist: half the rate of the cells.
  subroutine check_ranking_options(o, nyquist, status, msg)
    type(ranking_options_t), intent(in) :: o
    real(wp), intent(in) :: nyquist
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k

    status = MLID_ERR_INPUT
    do k = 1, size(o%names)
      if (all(to_lower(o%names(k)) /= CANDIDATE_NAMES)) then
        msg = 'candidates: unknown candidate '''//trim(o%names(k))//''': use '//choices(CANDIDATE_NAMES)
        return
      end if
      if (any(to_lower(o%names(k)) == to_lower(o%names(:k - 1)))) then
        msg = 'candidates: '''//trim(o%names(k))//''' is listed twice'
        return
      end if
    end do
    if (all(to_lower(o%compare) /= COMPARE_NAMES)) then
      msg = 'compare must be '//choices(COMPARE_NAMES)//', got '''//trim(o%compare)//''''
    else if (all(to_lower(o%rank_by) /= RANK_BY_NAMES)) then
      msg = 'rank_by must be '//choices(RANK_BY_NAMES)//', got '''//trim(o%rank_by)//''''
    else if (.not. all(ieee_is_finite([o%f_min, o%f_max, o%pulse_width])) .or. &
             o%f_min < 0.0_wp .or. o%f_max < 0.0_wp .or. o%pulse_width < 0.0_wp) then
      msg = 'f_min, f_max and pulse_width must be finite and >= 0 (0: from the model)'
    else if (o%f_min > 0.0_wp .and. .not. o%f_max > 0.0_wp) then
      msg = 'f_min needs f_max (the band is the model''s when neither is given)'
    else if (o%f_max > 0.0_wp .and. .not. o%f_max > o%f_min) then
      msg = 'the band needs f_max > f_min'
    else if (o%f_max > nyquist) then
      msg = 'f_max ='//es_text(o%f_max, 10, 3)//' Hz is above the cells'' Nyquist frequency'// &
            es_text(nyquist, 10, 3)//' Hz'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine check_ranking_options

  !> Rank the candidates of o for the design d of the model (f, g, h) on n
  !> cells of [0, T], each scaled to level (o%compare's energy or peak);
  !> uopt: the design's own input on the cells (nu per cell), 'optimal';
  !> fplant: the plant's F (without a servo's states), whose modes set the
  !> default band and base pulse.
  subroutine rank_candidates(d, f, g, h, fplant, t, n, o, level, uopt, r, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), fplant(:, :), t, level, uopt(:)
    integer, intent(in) :: n
    type(ranking_options_t), intent(in) :: o
    type(ranking_t), intent(out) :: r
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: nc, k, ierr

    call check_ranking_options(o, 0.5_wp*n/t, status, msg)
    if (status /= MLID_OK) return
    status = MLID_ERR_INPUT
    if (.not. (level > 0.0_wp .and. ieee_is_finite(level))) then
      msg = 'the common '//trim(o%compare)//' must be > 0 and finite'
      return
    end if
    if (size(uopt) /= n*d%nu .or. n < 2) then
      msg = 'the design''s input must be on the cells (nu per cell, at least 2 cells)'
      return
    end if
    nc = size(o%names)
    r%names = to_lower(o%names)
    r%compare = to_lower(o%compare)
    r%rank_by = to_lower(o%rank_by)
    r%level = level
    allocate (r%u(n*d%nu, nc), r%detail(nc), r%energy(nc), r%peak(nc), r%mm(d%m, d%m, nc), &
              r%det(nc), r%trace(nc), r%sigma(d%m, nc), r%x_peak(d%nx, nc), r%x_rms(d%nx, nc), &
              r%y_peak(d%ny, nc), r%y_rms(d%ny, nc), stat=ierr)
    if (ierr /= 0) then
      call no_memory('the candidates'' inputs and information', &
                     real(nc, wp)*(n*d%nu + d%m*d%m), status, msg)
      return
    end if
    do k = 1, nc
      call candidate(r%names(k), fplant, d%nu, t, n, o, uopt, r%u(:, k), r%detail(k), status, &
                     msg)
      if (status == MLID_OK) call scale(r%u(:, k), t/n, r%compare, level, status, msg)
      if (status == MLID_OK) call evaluate(d, f, g, h, t, n, r, k, status, msg)
      if (status /= MLID_OK) then
        msg = trim(r%names(k))//': '//msg
        return
      end if
    end do
    r%order = ranked(merge(r%det, r%trace, r%rank_by == 'det'), r%trace)
  end subroutine rank_candidates

  !> Candidate name on the cells (nu per cell), unscaled; detail its settings.
  subroutine candidate(name, f, nu, t, n, o, uopt, u, detail, status, msg)
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: f(:, :), t, uopt(:)
    integer, intent(in) :: nu, n
    type(ranking_options_t), intent(in) :: o
    real(wp), intent(out) :: u(:)
    character(len=*), intent(out) :: detail
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: w(:)
    real(wp) :: band(2), wmax
    integer :: j, k0, nw

    u = 0.0_wp
    call model_band(f, nu, t, n, o, wmax, band, status, msg)
    if (status /= MLID_OK) return
    select case (name)
    case ('optimal')
      u = uopt
      detail = 'the design''s input'
    case ('multisine')
      call all_inputs_multisine(band, nu, t, n, u, detail, status, msg)
    case default            ! input j in the j-th window of T
      do j = 1, nu
        k0 = ((j - 1)*n)/nu
        nw = (j*n)/nu - k0
        allocate (w(nw))
        call one_input(name, band, wmax, t/n, o%pulse_width, w, detail, status, msg)
        if (status /= MLID_OK) return
        u(k0*nu + j:(k0 + nw - 1)*nu + j:nu) = w
        deallocate (w)
      end do
    end select
  end subroutine candidate

  !> w_max, the largest |eigenvalue| of F (at least 2 pi/T), and the band
  !> [Hz] of the multisine and sweeps: o's, else [1/T, w_max/pi] widened to
  !> 2 nu harmonics of 1/T and held below 0.4 of the cells' rate.
  subroutine model_band(f, nu, t, n, o, wmax, band, status, msg)
    real(wp), intent(in) :: f(:, :), t
    integer, intent(in) :: nu, n
    type(ranking_options_t), intent(in) :: o
    real(wp), intent(out) :: wmax, band(2)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: wr(size(f, 1)), wi(size(f, 1))
    integer :: info

    call general_eig(f, wr, wi, info)
    if (info /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'the eigenvalues of F could not be found'
      return
    end if
    wmax = max(2.0_wp*PI/t, maxval(hypot(wr, wi)))
    band = [1.0_wp/t, min(max(wmax/PI, 2.0_wp*nu/t), 0.4_wp*n/t)]
    if (o%f_max > 0.0_wp) band = [max(o%f_min, 0.0_wp), o%f_max]
    status = MLID_OK
    msg = ''
  end subroutine model_band

  !> Orthogonal multisines of minimum peak factor on every input at once
  !> (mlid_signals), flat power over the band's harmonics of 1/T.
  subroutine all_inputs_multisine(band, nu, t, n, u, detail, status, msg)
    real(wp), intent(in) :: band(2), t
    integer, intent(in) :: nu, n
    real(wp), intent(out) :: u(:)
    character(len=*), intent(out) :: detail
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, allocatable :: k(:), owner(:)
    real(wp), allocatable :: us(:, :), ph(:), ampl(:)
    real(wp) :: rpf0(nu), rpf(nu)
    integer :: j, ierr

    call multisine_band(band(1), band(2), t/n, n, nu, k, owner, status, msg)
    if (status /= MLID_OK) return
    allocate (us(n + 1, nu), ph(size(k)), ampl(size(k)), stat=ierr)
    if (ierr /= 0) then
      call no_memory('the candidate multisines', real(n + 1, wp)*nu, status, msg)
      return
    end if
    call multisine(k, owner, spread(1.0_wp, 1, size(k)), spread(1.0_wp, 1, nu), &
                   MULTISINE_ITERATIONS, us, ph, ampl, rpf0, rpf, status, msg)
    if (status /= MLID_OK) return
    do j = 1, nu
      u(j::nu) = us(1:n, j)
    end do
    detail = trim(band_text(band))//', '//itoa(size(k))//' harmonics'
  end subroutine all_inputs_multisine

  !> One input's signal on a window of size(w) cells of length hc.
  subroutine one_input(name, band, wmax, hc, pulse, w, detail, status, msg)
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: band(2), wmax, hc, pulse
    real(wp), intent(out) :: w(:)
    character(len=*), intent(out) :: detail
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: pw, tw
    integer :: nclock, order

    tw = size(w)*hc
    select case (name)
    case ('doublet', '3211')
      pw = pulse
      if (pw <= 0.0_wp) pw = DOUBLET_PEAK/wmax
      pw = max(1, min(nint(pw/hc), size(w)/merge(2, 7, name == 'doublet')))*hc
      call input_signal(name, 1.0_wp, 0.0_wp, pw, hc, w, status, msg)
      detail = 'base pulse '//trim(adjustl(es_text(pw, 10, 3)))//' s'
    case ('sweep', 'log_sweep')      ! a log sweep cannot start at 0 Hz: at least 1e-3/window
      call sweep(merge('linear', 'log   ', name == 'sweep'), max(band(1), 1.0e-3_wp/tw), band(2), &
                 1.0_wp, 1.0_wp, 0.0_wp, hc, w, status, msg)
      detail = band_text(band)
    case default         ! prbs
      nclock = max(1, nint(0.44_wp/(band(2)*hc)))
      order = 2
      do while (order < 20 .and. (2**order - 1)*nclock < size(w))
        order = order + 1
      end do
      call prbs(order, nclock, 1.0_wp, w, status, msg)
      detail = 'clock '//trim(adjustl(es_text(nclock*hc, 10, 3)))//' s, order '//itoa(order)
    end select
  end subroutine one_input

  function band_text(band) result(text)
    real(wp), intent(in) :: band(2)
    character(len=48) :: text
    text = trim(adjustl(es_text(band(1), 10, 3)))//' to '//trim(adjustl(es_text(band(2), 10, 3)))// &
           ' Hz'
  end function band_text

  !> u scaled to energy sum(u^2) hc = level, or to peak max |u| = level.
  subroutine scale(u, hc, compare, level, status, msg)
    real(wp), intent(inout) :: u(:)
    real(wp), intent(in) :: hc, level
    character(len=*), intent(in) :: compare
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: now

    now = maxval(abs(u))
    if (compare == 'energy') now = sqrt(sum(u**2)*hc)
    if (.not. (now > 0.0_wp .and. ieee_is_finite(now))) then
      status = MLID_ERR_INPUT
      msg = 'the input is zero (or not finite) on the cells'
      return
    end if
    u = u*(merge(sqrt(level), level, compare == 'energy')/now)
    status = MLID_OK
    msg = ''
  end subroutine scale

  !> Candidate k's information, its summary, energy, peak and the peak and
  !> rms of the states and outputs over [0, T].
  subroutine evaluate(d, f, g, h, t, n, r, k, status, msg)
    type(design_t), intent(in) :: d
    real(wp), intent(in) :: f(:, :), g(:, :), h(:, :), t
    integer, intent(in) :: n, k
    type(ranking_t), intent(inout) :: r
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: x(:, :), y(:, :), wt(:)
    real(wp) :: eig(d%m)
    integer :: ierr

    call input_information(d, t, n, r%u(:, k), r%mm(:, :, k), status, msg)
    if (status /= MLID_OK) return
    call information_summary(r%mm(:, :, k), r%det(k), r%trace(k), r%sigma(:, k), eig, status)
    if (status /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'the information matrix could not be decomposed'
      return
    end if
    r%energy(k) = sum(r%u(:, k)**2)*t/n
    r%peak(k) = maxval(abs(r%u(:, k)))
    allocate (x(d%nx, 0:n*NS), wt(0:n*NS), y(d%ny, 0:n*NS), stat=ierr)
    if (ierr /= 0) then
      call no_memory('the states and outputs under a candidate', real(d%nx + d%ny + 1, wp)* &
                     (n*NS + 1), status, msg)
      return
    end if
    call input_response(f, g, t, n, NS, r%u(:, k), x, status, msg)
    if (status /= MLID_OK) return
    y = matmul(h, x)
    wt = simpson_weights(n*NS + 1, t)
    r%x_peak(:, k) = maxval(abs(x), dim=2)
    r%y_peak(:, k) = maxval(abs(y), dim=2)
    r%x_rms(:, k) = sqrt(matmul(x**2, wt)/t)
    r%y_rms(:, k) = sqrt(matmul(y**2, wt)/t)
  end subroutine evaluate

  !> The places in descending order of key (ties: of tie, then as given).
  pure function ranked(key, tie) result(order)
    real(wp), intent(in) :: key(:), tie(:)
    integer :: order(size(key)), i, j, p

    order = [(i, i=1, size(key))]
    do i = 2, size(key)              ! insertion sort: a handful of candidates
      p = order(i)
      j = i - 1
      do while (j >= 1)
        if (.not. better(p, order(j))) exit
        order(j + 1) = order(j)
        j = j - 1
      end do
      order(j + 1) = p
    end do

  contains

    pure logical function better(a, b)
      integer, intent(in) :: a, b
      better = key(a) > key(b) .or. (key(a) == key(b) .and. tie(a) > tie(b))
    end function better

  end function ranked

end module mlid_input_ranking
