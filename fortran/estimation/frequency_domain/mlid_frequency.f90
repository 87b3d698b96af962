!> Frequency-domain estimation of linear models (kind 'linear'), beside the
!> time-domain methods: the record's finite Fourier transform (mlid_fourier)
!> at n_freq frequencies evenly spaced over the band f_min .. f_max (both
!> included), each manoeuvre's own, and a likelihood of the transformed
!> data that the modified Newton-Raphson (mlid_newton) iterates as it does
!> the time-domain ones, with the same free/fixed/tie/prior/bounds machinery
!> and Cramer-Rao bounds.
!>
!> frequency output error: Y(w) = He (i w I - Fe)^-1 G U(w) + D U(w), with
!>   Fe = F + G K, He = H + D K (K, the model's fixed input feedback);
!> frequency equation error: every state measured by an output (h_i = x_k,
!>   no parameter in it), the state equations i w X_k(w) = (F X + G V)_k and
!>   the other outputs' Y_i = (H X + D V)_i with the measured states in X and
!>   V = U + K X: residuals linear in F, G, H, D, so a quadratic cost that
!>   the Newton iteration solves in one step (and a second to settle S).
!>
!> Both take the cost of complex Gaussian residuals V_k at the frequencies,
!>   J = sum_k c_k V_k^* S^-1 V_k + n ln|S|,  S = (1/n) sum_k c_k Re(V_k V_k^*),
!> n = sum_k c_k (S diagonal unless noise = 'full'), its gradient -2 sum c_k
!> Re(dV^* S^-1 V) and information 2 sum c_k Re(dV^* S^-1 dV) at S-hat, as
!> output error takes R.  The transforms of white noise at frequencies
!> closer than 1/T (T the manoeuvre's length) are correlated, and a grid
!> of spacing df finer than that holds only df T independent frequencies
!> per frequency: the weight c_k = min(1, df T) makes the information that
!> of the independent ones (with c_k = 1 a dense grid would claim sigmas
!> too small by sqrt(df T)).
!>
!> The transformed record is carried to the likelihood in the time-domain
!> arrays' places (so mlid_newton needs no second interface): column pair
!> 2k-1, 2k holds frequency k's real and imaginary parts, t(2k-1) = t(2k) =
!> its w (rad/s); u holds U (and for equation error the measured states X
!> below it) and below them the NEXTRA rows of each frequency's manoeuvre
!> (its phases at t0 and t1, weight c_k, number, length), y the measured
!> left-hand sides Y (equation error: i w Y for the outputs that measure a
!> state).
!>
!> What the transform brings in besides the transfer function: over a
!> manoeuvre from t0 to t1 the state equations' transform holds the
!> initial and final states, x(t0) exp(-i w t0) - x(t1) exp(-i w t1), and
!> any constant forcing k (trim, state biases) times E(w), the transform of
!> 1; the outputs hold their offsets o (biases, trim) times E and their
!> drift rates d times R(w), the transform of t - t0.  These transient
!> terms eta = [x(t0), x(t1), k, o, d] of each manoeuvre are linear in the
!> residuals: for each theta the cost's minimum over them (and S) is taken
!> by weighted least squares (terms linearly dependent on the others left
!> out), and the information of theta is that with them unknown (the Schur
!> complement).  So constant biases, trim values and linear drifts drop out
!> exactly, and the band may start below 1/T.  Each channel's mean is
!> removed before the transform (for the numbers' size only: the terms
!> take it up).  x0, the output biases and bx are therefore not parameters
!> here: free x0, biases, noise statistics, delays, Gamma, K or bx are
!> refused with a message.  With p parameters and transient terms fitted to
!> N effective real data (2 ny sum_k c_k), the weights are multiplied by (N
!> - p)/N: the information at the unbiased S (the Monte Carlo check of
!> tests/test_frequency_fit.py).
module mlid_frequency
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_SINGULAR
  use mlid_models, only: model_t, linear_model_t
  use mlid_options, only: options_t, METHOD_FREQ_EE
  use mlid_params, only: param_map_t, input_delays, output_delays, stabilized
  use mlid_fourier, only: fourier_transform
  use mlid_linalg, only: chol_inverse, chol_solve, independent_columns
  use mlid_text, only: itoa
  use mlid_sampling, only: record_uniform_step
  use mlid_interrupt, only: check_interrupt
  implicit none
  private
  public :: freq_record, freq_likelihood, freq_grid

  real(wp), parameter :: TWO_PI = 8.0_wp*atan(1.0_wp)
  !> Rows of the transformed record's u after the inputs (and measured
  !> states): exp(-i w t0), exp(-i w t1) (complex, packed as the data), the
  !> weight c_k, the manoeuvre, its length t1 - t0.
  integer, parameter :: NEXTRA = 5
  !> The transient terms: a term whose column's squared distance from the
  !> span of those kept is below ETA_RCOND of its squared length is left
  !> out (near-dependent columns; mlid_linalg's independent_columns), and the
  !> alternation with S stops when the cost changes by less than ETA_TOL
  !> (relative), after ETA_SWEEPS at most.
  real(wp), parameter :: ETA_RCOND = 1.0e-12_wp, ETA_TOL = 1.0e-14_wp
  !> A sweep's S from the weighted products only while each output's stays
  !> above CANCEL of r0's (at most six digits lost to cancellation).
  real(wp), parameter :: CANCEL = 1.0e-6_wp
  integer, parameter :: ETA_SWEEPS = 200
  complex(wp), parameter :: IU = (0.0_wp, 1.0_wp)

contains

  !> The band's frequencies, Hz: n_freq evenly from f_min to f_max.
  pure function freq_grid(opt) result(f)
    type(options_t), intent(in) :: opt
    real(wp) :: f(opt%n_freq)
    integer :: k
    f = [(opt%f_min + (opt%f_max - opt%f_min)*(k - 1)/real(opt%n_freq - 1, wp), &
          k=1, opt%n_freq)]
  end function freq_grid

  !> The transformed record (the layout above) of t, u, y with the
  !> manoeuvres starting at the samples pm%l%seg, after the checks of model,
  !> parameters, sampling and band.
  subroutine freq_record(m, theta, pm, t, u, y, opt, tf, uf, yf, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), t(:), u(:, :), y(:, :)
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    real(wp), allocatable, intent(out) :: tf(:), uf(:, :), yf(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: w(:), x(:, :)
    complex(wp), allocatable :: xf(:, :)
    integer :: xout(m%nx), nseg, nk, s, j0, j1, k, c, i, nu, ny, ie
    real(wp) :: dt
    complex(wp) :: p0, p1

    call freq_check(m, theta, pm, opt, xout, status, msg)
    if (status /= MLID_OK) return
    nu = m%nu
    ny = m%ny
    nseg = pm%l%nseg
    nk = opt%n_freq
    w = TWO_PI*freq_grid(opt)
    allocate (tf(2*nk*nseg), uf(nu + merge(m%nx, 0, opt%method == METHOD_FREQ_EE) + NEXTRA, &
              2*nk*nseg), yf(ny, 2*nk*nseg))
    ie = size(uf, 1) - NEXTRA
    status = MLID_ERR_INPUT
    do s = 1, nseg
      j0 = pm%l%seg(s)
      j1 = size(t)
      if (s < nseg) j1 = pm%l%seg(s + 1) - 1
      if (j1 - j0 < 2) then
        msg = 'manoeuvre '//itoa(s)//' has fewer than three samples to transform'
        return
      end if
      call record_uniform_step(t(j0:j1), dt, status, msg)
      if (status /= MLID_OK) then
        if (nseg > 1) msg = 'manoeuvre '//itoa(s)//': '//trim(msg)
        return
      end if
      status = MLID_ERR_INPUT
      if (opt%f_max >= 0.5_wp/dt) then
        write (msg, '(a,g0.6,a,g0.6,a,i0)') 'f_max = ', opt%f_max, ' Hz is not below the '// &
          'Nyquist frequency ', 0.5_wp/dt, ' Hz of manoeuvre ', s
        return
      end if
      ! each channel less its mean: constant biases and trim drop out
      allocate (x(nu + ny, j1 - j0 + 1))
      x(1:nu, :) = u(:, j0:j1)
      x(nu + 1:, :) = y(:, j0:j1)
      do i = 1, nu + ny
        x(i, :) = x(i, :) - sum(x(i, :))/size(x, 2)
      end do
      allocate (xf(nu + ny, nk))
      call fourier_transform(x, dt, t(j0), w, xf)
      status = MLID_OK
      call check_interrupt(status, msg)
      if (status /= MLID_OK) return
      do k = 1, nk
        c = 2*((s - 1)*nk + k) - 1
        tf(c:c + 1) = w(k)
        p0 = exp(-IU*w(k)*t(j0))
        p1 = exp(-IU*w(k)*t(j1))
        uf(ie + 1, c:c + 1) = [real(p0, wp), aimag(p0)]
        uf(ie + 2, c:c + 1) = [real(p1, wp), aimag(p1)]
        uf(ie + 3, c:c + 1) = min(1.0_wp, (opt%f_max - opt%f_min)/(nk - 1)*(t(j1) - t(j0)))
        uf(ie + 4, c:c + 1) = s
        uf(ie + 5, c:c + 1) = t(j1) - t(j0)
        uf(1:nu, c) = real(xf(1:nu, k), wp)
        uf(1:nu, c + 1) = aimag(xf(1:nu, k))
        yf(:, c) = real(xf(nu + 1:, k), wp)
        yf(:, c + 1) = aimag(xf(nu + 1:, k))
        if (opt%method == METHOD_FREQ_EE) then
          uf(nu + 1:, c) = yf(xout, c)            ! the measured states
          uf(nu + 1:, c + 1) = yf(xout, c + 1)
          do i = 1, m%nx                          ! i w X: the state equations' left side
            yf(xout(i), c) = -w(k)*uf(nu + i, c + 1)
            yf(xout(i), c + 1) = w(k)*uf(nu + i, c)
          end do
        end if
      end do
      deallocate (xf, x)
    end do
    status = MLID_OK
    msg = ''
  end subroutine freq_record

  !> What the frequency-domain methods take: the linear model kind, free
  !> entries of F, G, H, D only, no time delays or stabilizing gain; for
  !> equation error every state measured (xout(k): the output measuring
  !> state k).
  subroutine freq_check(m, theta, pm, opt, xout, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    integer, intent(out) :: xout(:)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=*), parameter :: WHY = ' has no meaning in the frequency domain (the '// &
      'transform leaves out trim, biases and initial states): fix it'
    status = MLID_ERR_INPUT
    xout = 0
    select type (m)
    type is (linear_model_t)
      if (size(pm%ix0) > 0) then
        msg = 'a free initial state x0'//WHY
      else if (size(pm%ib) > 0) then
        msg = 'a free output bias'//WHY
      else if (size([pm%iq, pm%ir, pm%is, pm%ip0, pm%ik]) > 0) then
        msg = 'the frequency-domain methods estimate the noise covariance from the residuals: '// &
              'fix q, r, s, p0 and stab'
      else if (size(pm%id) + size(pm%iu) > 0 .or. output_delays(theta, pm) .or. &
               input_delays(theta, pm) .or. stabilized(theta, pm%l)) then
        msg = 'time delays and the stabilizing gain are not taken by the frequency-domain '// &
              'methods: leave them zero and fixed'
      else if (any(pm%im > m%od + m%ny*m%nu)) then
        msg = 'the frequency-domain methods estimate entries of F, G, H and D: fix gamma, '// &
              'the input feedback k and the state biases bx'
      else if (opt%method == METHOD_FREQ_EE) then
        call state_outputs(m, theta, pm, xout, msg)
        if (len_trim(msg) == 0) status = MLID_OK
      else
        status = MLID_OK
        msg = ''
      end if
    class default
      msg = 'the frequency-domain methods are for the linear model kind (kind = ''linear'')'
    end select
  end subroutine freq_check

  !> The output that measures each state (row e_k of H, zero row of D,
  !> neither moving): the equation-error method's measured states.
  subroutine state_outputs(m, theta, pm, xout, msg)
    type(linear_model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    type(param_map_t), intent(in) :: pm
    integer, intent(out) :: xout(:)
    character(len=*), intent(out) :: msg
    real(wp) :: f(m%nx, m%nx), g(m%nx, m%nu), h(m%ny, m%nx), d(m%ny, m%nu), kf(m%nu, m%nx)
    logical :: moving(m%ny)
    integer :: i, k, e
    call m%matrices(theta, f, g, h, d, kf)
    moving = .false.
    do k = 1, size(pm%im)
      e = pm%im(k)
      if (e > m%oh .and. e <= m%oh + m%ny*m%nx) moving(mod(e - m%oh - 1, m%ny) + 1) = .true.
      if (e > m%od .and. e <= m%od + m%ny*m%nu) moving(mod(e - m%od - 1, m%ny) + 1) = .true.
    end do
    xout = 0
    do k = 1, m%nx
      do i = 1, m%ny
        if (xout(k) == 0 .and. .not. moving(i) .and. all(d(i, :) == 0.0_wp) .and. &
            h(i, k) == 1.0_wp .and. count(h(i, :) /= 0.0_wp) == 1) xout(k) = i
      end do
    end do
    msg = ''
    if (any(xout == 0)) msg = 'frequency_equation_error needs every state measured (an '// &
      'output h = x with no free parameter): state '//itoa(findloc(xout, 0, 1))//' is not'
  end subroutine state_outputs

  !> Cost, S-hat (rhat), the fitted left-hand sides (yhat, the layout above,
  !> with the transient terms) and with grad and info their gradient and
  !> information at S-hat and the transient terms' estimate; sens and
  !> msens as mlid_likelihood's.
  subroutine freq_likelihood(m, theta, pm, tf, uf, yf, opt, cost, rhat, yhat, status, msg, grad, &
                             info, sens, msens, nterms)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), tf(:), uf(:, :), yf(:, :)
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: cost, rhat(:, :), yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: grad(:), info(:, :), sens(:, :), msens(:, :)
    integer, intent(out), optional :: nterms    !< the transient terms estimated (independent)
    real(wp), allocatable :: d(:, :, :), bas(:, :, :), r0(:, :), r(:, :), a(:, :, :), cw(:), &
                             eta(:), xi(:), tsc(:), c(:, :), gm(:, :, :, :), mtt(:, :), &
                             mbt(:, :), mbb(:, :)
    integer, allocatable :: keep(:)
    complex(wp), allocatable :: ainv(:, :, :), pa(:, :, :), xs(:, :)
    real(wp) :: sinv(m%ny, m%ny), logdet, dof, shrink
    integer :: xout(m%nx), nc, ne, i, ndrop

    cost = huge(1.0_wp)
    nc = size(tf)
    status = MLID_ERR_INPUT
    msg = 'the frequency-domain likelihood takes the transformed record (mlid_frequency)'
    if (mod(nc, 2) /= 0 .or. nc == 0) return
    if (any(tf(1::2) /= tf(2::2))) return
    call freq_check(m, theta, pm, opt, xout, status, msg)
    if (status /= MLID_OK) return
    cw = uf(size(uf, 1) - NEXTRA + 3, :)               ! each column's weight c_k
    ne = nint(maxval(uf(size(uf, 1) - NEXTRA + 4, :)))*(3*m%nx + 2*m%ny)
    allocate (bas(m%ny, nc, ne), ainv(m%nx, m%nx, nc/2), pa(m%ny, m%nx, nc/2), xs(m%nx, nc/2))
    select type (m)
    type is (linear_model_t)
      call model_terms(m, theta, tf, uf, opt%method == METHOD_FREQ_EE, xout, yhat, bas, ainv, pa, &
                       xs, status, msg)
    end select
    if (status /= MLID_OK) return
    r0 = yf - yhat
    call independent_terms(bas, r0, cw, opt%full_r, keep, tsc, gm)
    ndrop = ne - size(keep)
    allocate (xi(size(keep)))
    call transients(r0, bas, keep, tsc, gm, cw, opt%full_r, xi, r, rhat, sinv, logdet, status, &
                    msg)
    if (status /= MLID_OK) return
    allocate (eta(ne))
    eta = 0.0_wp
    eta(keep) = tsc*xi
    ! S-hat is the residuals' mean square; with p parameters and transient
    ! terms fitted to N effective real data it is low by (N - p)/N, and an
    ! information taken with it high by N/(N - p): the weights times (N -
    ! p)/N make cost, gradient and information those at the unbiased S
    ! (S-hat itself, a weighted mean, does not change)
    dof = m%ny*sum(cw) - (pm%nf + ne - ndrop)
    if (.not. dof > 0.0_wp) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0,a,i0,a)') 'the band holds too few independent frequencies for the ', &
        pm%nf, ' parameters and ', ne - ndrop, ' transient terms: widen it or add frequencies'
      return
    end if
    shrink = dof/(m%ny*sum(cw))
    cw = cw*shrink
    if (present(nterms)) nterms = ne - ndrop
    yhat = yf - r
    ! sum_c c_c r' S^-1 r = (1/2) sum(c) tr(S^-1 S-hat), S-hat of the same residuals
    cost = 0.5_wp*sum(cw)*(sum(sinv*rhat) + logdet)
    if (.not. ieee_is_finite(cost)) then
      status = MLID_ERR_SINGULAR
      msg = 'cost is not finite'
      return
    end if
    if (.not. (present(grad) .and. present(info))) return

    allocate (d(m%ny, nc, pm%nf))
    select type (m)
    type is (linear_model_t)
      call sensitivities(m, theta, pm, tf, uf, opt%method == METHOD_FREQ_EE, xout, ainv, pa, xs, &
                         eta, d)
    end select
    allocate (a(m%ny, nc, 1))
    call weigh(reshape(r, [m%ny, nc, 1]), sinv, cw, a)
    mtt = cross(d, a, m%ny*nc, pm%nf, 1)
    grad = -mtt(:, 1)
    deallocate (a)
    allocate (a(m%ny, nc, pm%nf))
    ! information of (theta, transients), the transients eliminated (Schur
    ! complement): the information of theta with them unknown; the blocks
    ! of theta (mtt), transients by theta (mbt) and transients (mbb, from
    ! their per-output products gm)
    call weigh(d, sinv, cw, a)
    allocate (c(size(keep), size(keep)))
    mtt = cross(d, a, m%ny*nc, pm%nf, pm%nf)
    mbt = spread(tsc, 2, pm%nf)*cross(bas(:, :, keep), a, m%ny*nc, size(keep), pm%nf)
    mbb = shrink*combined(gm, sinv)       ! gm: of the weights before the shrink
    call chol_inverse(mbb, c, logdet, i)
    if (i /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'the transient terms'' information is singular'
      return
    end if
    info = 0.5_wp*(mtt + transpose(mtt)) - matmul(transpose(mbt), matmul(c, mbt))
    info = 0.5_wp*(info + transpose(info))
    if (present(msens)) msens = info
    if (present(sens)) then
      do i = 1, m%ny
        sens(i, :) = sqrt(matmul(cw, d(i, :, 1:pm%nf)**2)/rhat(i, i))
      end do
    end if
  end subroutine freq_likelihood

  !> The weighted products of the columns b (ny, nc, n) output by output,
  !> gm(:, :, i, j) = sum_c c_c b(i, c, :)' b(j, c, :), for the pairs that
  !> S couples (i = j only unless full): the information 2 sum_c c_c b_c'
  !> S^-1 b_c of any S is then sum_ij 2 S^-1_ij gm_ij (combined), so the
  !> alternation with S costs no pass over the columns.  Each output's
  !> columns that are zero there (another output's offset or drift) are
  !> left out of its products.
  subroutine grams(b, cw, full, gm)
    real(wp), intent(in) :: b(:, :, :), cw(:)
    logical, intent(in) :: full
    real(wp), allocatable, intent(out) :: gm(:, :, :, :)
    real(wp), allocatable :: bj(:, :), wbj(:, :)
    logical :: used(size(b, 3), size(b, 1))
    integer :: i, j, k, n, ny
    integer, allocatable :: ki(:), kj(:)
    ny = size(b, 1)
    n = size(b, 3)
    allocate (gm(n, n, ny, ny))
    gm = 0.0_wp
    if (n == 0) return
    do i = 1, ny
      used(:, i) = [(any(b(i, :, k) /= 0.0_wp), k=1, n)]
    end do
    do j = 1, ny
      kj = pack([(k, k=1, n)], used(:, j))
      bj = b(j, :, kj)            ! gathered once (the strided read), weighted apart
      allocate (wbj, mold=bj)
      do k = 1, size(kj)
        wbj(:, k) = cw*bj(:, k)
      end do
      do i = 1, ny
        if (i == j) then
          gm(kj, kj, j, j) = matmul(transpose(bj), wbj)
        else if (full) then
          ki = pack([(k, k=1, n)], used(:, i))
          gm(ki, kj, i, j) = matmul(transpose(b(i, :, ki)), wbj)
        end if
      end do
      deallocate (wbj)
    end do
  end subroutine grams

  !> x' y of x (nr, n1) and y (nr, n2), as the columns of arrays of any
  !> shape with nr rows' worth of elements (no reshaped copies).
  pure function cross(x, y, nr, n1, n2) result(z)
    integer, intent(in) :: nr, n1, n2
    real(wp), intent(in) :: x(nr, n1), y(nr, n2)
    real(wp) :: z(n1, n2)
    z = matmul(transpose(x), y)
  end function cross

  !> r = r0 - b(:, keep) e of b (nr, n), as cross takes its arrays.
  pure subroutine less_columns(r0, b, keep, e, nr, n, r)
    integer, intent(in) :: nr, n, keep(:)
    real(wp), intent(in) :: r0(nr), b(nr, n), e(:)
    real(wp), intent(out) :: r(nr)
    integer :: k
    r = r0
    do k = 1, size(keep)
      r = r - e(k)*b(:, keep(k))
    end do
  end subroutine less_columns

  !> sum_ij 2 sinv_ij gm(:, :, i, j) (grams): the information 2 sum_c c_c
  !> b_c' S^-1 b_c, symmetric (gm(:, :, j, i) = gm(:, :, i, j)' and sinv
  !> symmetric: the lower triangle, mirrored).
  function combined(gm, sinv) result(mm)
    real(wp), intent(in) :: gm(:, :, :, :), sinv(:, :)
    real(wp) :: mm(size(gm, 1), size(gm, 2))
    integer :: i, j, k, l
    mm = 0.0_wp
    do j = 1, size(sinv, 2)
      do i = 1, size(sinv, 1)
        if (sinv(i, j) == 0.0_wp) cycle
        do l = 1, size(mm, 2)
          mm(l:, l) = mm(l:, l) + 2.0_wp*sinv(i, j)*gm(l:, l, i, j)
        end do
      end do
    end do
    do l = 2, size(mm, 2)
      do k = 1, l - 1
        mm(k, l) = mm(l, k)
      end do
    end do
  end function combined

  !> a = 2 c S^-1 b_c for each column c of b (ny, nc, n): rows scaled when
  !> S is diagonal.
  subroutine weigh(b, sinv, cw, a)
    real(wp), intent(in) :: b(:, :, :), sinv(:, :), cw(:)
    real(wp), intent(out) :: a(:, :, :)
    real(wp) :: w(size(b, 1), size(b, 2))
    integer :: i, j, c
    if (count(sinv /= 0.0_wp) == size(sinv, 1)) then
      do c = 1, size(b, 2)
        do i = 1, size(b, 1)
          w(i, c) = 2.0_wp*cw(c)*sinv(i, i)
        end do
      end do
      do j = 1, size(b, 3)
        a(:, :, j) = w*b(:, :, j)
      end do
    else
      do j = 1, size(b, 3)
        a(:, :, j) = 2.0_wp*matmul(sinv, b(:, :, j))*spread(cw, 1, size(b, 1))
      end do
    end if
  end subroutine weigh

  !> An independent set of the transient terms' columns b (ny, nc, n)
  !> spanning the same, keep (independent_columns of their normalised
  !> information, weighted by the residuals r0's mean squares), and their
  !> scales tsc (that normalisation).  Exact dependencies occur: with every
  !> state measured (H invertible) the output offsets are the states'.  gm:
  !> the grams of the kept columns times their scales (the pairs S couples,
  !> full or diagonal).
  subroutine independent_terms(b, r0, cw, full, keep, tsc, gm)
    real(wp), intent(in) :: b(:, :, :), r0(:, :), cw(:)
    logical, intent(in) :: full
    integer, allocatable, intent(out) :: keep(:)
    real(wp), allocatable, intent(out) :: tsc(:), gm(:, :, :, :)
    real(wp) :: w0(size(r0, 1), size(r0, 1)), m0(size(b, 3), size(b, 3))
    real(wp), allocatable :: g0(:, :, :, :)
    integer :: i, j, k, n, nk, ny
    n = size(b, 3)
    ny = size(b, 1)
    w0 = 0.0_wp
    do i = 1, ny
      w0(i, i) = sum(cw)/max(sum(cw*r0(i, :)**2), tiny(1.0_wp))
    end do
    call grams(b, cw, full, g0)
    m0 = combined(g0, w0)
    call independent_columns(m0, ETA_RCOND, keep)
    nk = size(keep)
    tsc = [(1.0_wp/sqrt(m0(keep(k), keep(k))), k=1, nk)]
    allocate (gm(nk, nk, ny, ny))
    gm = 0.0_wp
    do j = 1, ny
      do i = 1, ny
        if (i /= j .and. .not. full) cycle
        do k = 1, nk
          gm(:, k, i, j) = tsc*g0(keep, keep(k), i, j)*tsc(k)
        end do
      end do
    end do
  end subroutine independent_terms

  !> The transient terms' estimate eta and S-hat together: the cost's
  !> minimum over both, alternating the weighted least squares for eta
  !> (given S) and S = (1/n) sum c Re(V V^*) (given eta) until the cost
  !> settles; r the residuals left, sinv and logdet of S.  The terms are
  !> eta of the independent columns bas(:, :, keep) times tsc
  !> (independent_terms; gm their grams).
  subroutine transients(r0, bas, keep, tsc, gm, cw, full, eta, r, s, sinv, logdet, status, msg)
    real(wp), intent(in) :: r0(:, :), bas(:, :, :), tsc(:), gm(:, :, :, :), cw(:)
    integer, intent(in) :: keep(:)
    logical, intent(in) :: full
    real(wp), intent(out) :: eta(:), s(:, :), sinv(:, :), logdet
    real(wp), allocatable, intent(out) :: r(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: g(size(eta)), cost, last, q
    real(wp) :: hr(size(eta), size(r0, 1), size(r0, 1)), q0(size(r0, 1), size(r0, 1)), &
                wr(size(r0, 2))
    integer :: it, i, j, k, ierr, ny
    ny = size(r0, 1)
    ! r0's and the columns' weighted products, q0(i, j) = sum_c c_c r0(i,
    ! c) r0(j, c) and hr(k, i, j) = tsc_k sum_c c_c bas(i, c, keep_k) r0(j,
    ! c): the least squares' right-hand side is sum_ij 2 S^-1_ij hr(:, i, j)
    ! and (with gm) the residuals' products sum_c c_c r(i, c) r(j, c) at any
    ! eta are q0 - eta' (hr(:, i, j) + hr(:, j, i)) + eta' gm(:, :, i, j)
    ! eta, so a sweep makes no pass over the columns
    q0 = 0.0_wp
    hr = 0.0_wp
    do j = 1, ny
      wr = cw*r0(j, :)
      do i = 1, ny
        if (i /= j .and. .not. full) cycle
        q0(i, j) = dot_product(r0(i, :), wr)
        do k = 1, size(keep)
          hr(k, i, j) = tsc(k)*dot_product(bas(i, :, keep(k)), wr)
        end do
      end do
    end do
    allocate (r(ny, size(r0, 2)))
    eta = 0.0_wp
    s = 0.0_wp
    last = huge(1.0_wp)
    do it = 1, ETA_SWEEPS
      do j = 1, ny             ! S given eta
        do i = 1, ny
          if (i /= j .and. .not. full) cycle
          q = q0(i, j)
          do k = 1, size(eta)
            q = q + eta(k)*(dot_product(gm(:, k, i, j), eta) - hr(k, i, j) - hr(k, j, i))
          end do
          s(i, j) = q/(0.5_wp*sum(cw))
        end do
      end do
      ! the products cancel when the terms take nearly all of r0: then this
      ! sweep's S from the residuals themselves
      if (any([(s(i, i) < CANCEL*q0(i, i)/(0.5_wp*sum(cw)), i=1, ny)])) then
        call less_columns(r0, bas, keep, tsc*eta, size(r0), size(bas, 3), r)
        call residual_products(r, cw, full, s)
      end if
      call spectrum(s, sinv, logdet, status, msg)
      if (status /= MLID_OK) return
      cost = 0.5_wp*sum(cw)*(sum(sinv*s) + logdet)
      if (size(eta) == 0 .or. abs(last - cost) <= ETA_TOL*max(1.0_wp, abs(cost))) exit
      last = cost
      g = 0.0_wp               ! eta given S: the weighted least squares on r0
      do j = 1, ny
        do i = 1, ny
          if (i == j .or. full) g = g + 2.0_wp*sinv(i, j)*hr(:, i, j)
        end do
      end do
      call chol_solve(combined(gm, sinv), g, eta, ierr)
      if (ierr /= 0) then
        status = MLID_ERR_SINGULAR
        msg = 'the transient terms'' information is singular'
        return
      end if
    end do
    ! the residuals, and S from them: the products above lose the digits
    ! the transient terms take from r0
    call less_columns(r0, bas, keep, tsc*eta, size(r0), size(bas, 3), r)
    call residual_products(r, cw, full, s)
    call spectrum(s, sinv, logdet, status, msg)
  end subroutine transients

  !> S = (1/n) sum_c c_c r_c r_c' of the residuals r (the pairs S couples).
  subroutine residual_products(r, cw, full, s)
    real(wp), intent(in) :: r(:, :), cw(:)
    logical, intent(in) :: full
    real(wp), intent(inout) :: s(:, :)
    real(wp) :: wr(size(r, 2))
    integer :: i, j
    do j = 1, size(r, 1)
      wr = cw*r(j, :)
      do i = 1, size(r, 1)
        if (i == j .or. full) s(i, j) = dot_product(r(i, :), wr)/(0.5_wp*sum(cw))
      end do
    end do
  end subroutine residual_products

  !> S^-1 and ln|S| of the residual spectrum S, or why there are none.
  subroutine spectrum(s, sinv, logdet, status, msg)
    real(wp), intent(in) :: s(:, :)
    real(wp), intent(out) :: sinv(:, :), logdet
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: i, ierr
    status = MLID_ERR_SINGULAR
    sinv = 0.0_wp
    logdet = 0.0_wp
    if (.not. all([(s(i, i) > tiny(1.0_wp), i=1, size(s, 1))])) then
      msg = 'a residual spectrum is zero or not finite: an output fitted exactly '// &
            '(noise-free data?)'
      return
    end if
    call chol_inverse(s, sinv, logdet, ierr)
    if (ierr /= 0) then
      msg = 'residual covariance is singular (outputs linearly dependent): use noise = '// &
            '''diagonal'''
      return
    end if
    status = MLID_OK
    msg = ''
  end subroutine spectrum

  !> The model's left-hand sides without the transient terms (y0), the
  !> transient terms' columns (bas: d y / d eta), and what the
  !> sensitivities need: (i w I - Fe)^-1 (ainv), He (i w I - Fe)^-1 (pa)
  !> and the states' transforms xs
  !> (output error: driven by U; equation error: measured).  Output error:
  !> X = A^-1 (G U + N eta), N = [p0 I, -p1 I, E I] over the manoeuvre's
  !> x(t0), x(t1) and constant forcing k (trim, state biases), E = (p0 -
  !> p1)/(i w) the transform of 1, Y = He X + D U + E o + R d with the
  !> outputs' offsets o and drift rates d, R = (E - (t1 - t0) p1)/(i w) the
  !> transform of t - t0.  Equation error: state row k: (F X + G V)_k + (N
  !> eta)_k + R d_k, the other rows (H X + D V)_i + E o_i + R d_i.
  subroutine model_terms(m, theta, tf, uf, ee, xout, y0, bas, ainv, pa, xs, status, msg)
    type(linear_model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), tf(:), uf(:, :)
    logical, intent(in) :: ee
    integer, intent(in) :: xout(:)
    real(wp), intent(out) :: y0(:, :), bas(:, :, :)     !< bas (ny, nc, neta)
    complex(wp), intent(out) :: ainv(:, :, :), pa(:, :, :), xs(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: f(m%nx, m%nx), g(m%nx, m%nu), h(m%ny, m%nx), d(m%ny, m%nu), kf(m%nu, m%nx), &
                fe(m%nx, m%nx), he(m%ny, m%nx), big
    complex(wp) :: a(m%nx, m%nx), p(m%ny, m%nx), uu(m%nu), v(m%nu), yy(m%ny), p0, p1, e, ramp, &
                   gu(m%nx), z
    integer :: c, k, i, j, l, ie, ne, s, nx, nu, ny
    logical :: ok

    nx = m%nx
    nu = m%nu
    ny = m%ny
    call m%matrices(theta, f, g, h, d, kf)
    fe = f + matmul(g, kf)
    he = h + matmul(d, kf)
    ie = size(uf, 1) - NEXTRA
    ne = 3*nx + 2*ny
    status = MLID_OK
    msg = ''
    bas = 0.0_wp
    do c = 1, size(tf), 2
      k = (c + 1)/2
      uu = cmplx(uf(1:nu, c), uf(1:nu, c + 1), wp)
      p0 = cmplx(uf(ie + 1, c), uf(ie + 1, c + 1), wp)
      p1 = cmplx(uf(ie + 2, c), uf(ie + 2, c + 1), wp)
      e = (p0 - p1)/(IU*tf(c))
      ramp = (e - uf(ie + 5, c)*p1)/(IU*tf(c))       ! the transform of t - t0
      s = (nint(uf(ie + 4, c)) - 1)*ne       ! this manoeuvre's terms: bas(:, :, s + 1:s + ne)
      do i = 1, ny
        call put(i, s + 3*nx + i, e)
        call put(i, s + 3*nx + ny + i, ramp)
      end do
      if (ee) then
        xs(:, k) = cmplx(uf(nu + 1:nu + nx, c), uf(nu + 1:nu + nx, c + 1), wp)
        v = uu + matmul(kf, xs(:, k))
        yy = matmul(h, xs(:, k)) + matmul(d, v)
        yy(xout) = matmul(f, xs(:, k)) + matmul(g, v)
        do i = 1, nx
          call put(xout(i), s + 3*nx + xout(i), (0.0_wp, 0.0_wp))   ! a state equation has no
          call put(xout(i), s + i, p0)                                ! output offset
          call put(xout(i), s + nx + i, -p1)
          call put(xout(i), s + 2*nx + i, e)
        end do
      else
        a = -fe
        do i = 1, nx
          a(i, i) = a(i, i) + IU*tf(c)
        end do
        big = max(1.0_wp, maxval(mag(a)))
        call complex_inverse(a, big, ainv(:, :, k), ok)
        if (.not. ok) then
          status = MLID_ERR_SINGULAR
          write (msg, '(a,g0.6,a)') 'i w I - F is singular at ', tf(c)/TWO_PI, &
            ' Hz: the model has a pole on the imaginary axis there'
          return
        end if
        gu = 0.0_wp
        do j = 1, nu
          gu = gu + scaled(g(:, j), uu(j))
        end do
        xs(:, k) = 0.0_wp
        do j = 1, nx
          xs(:, k) = xs(:, k) + ainv(:, j, k)*gu(j)
        end do
        yy = 0.0_wp
        do j = 1, nx
          do i = 1, ny
            z = 0.0_wp
            do l = 1, nx
              z = z + scaled(he(i, l), ainv(l, j, k))
            end do
            p(i, j) = z
          end do
          yy = yy + scaled(he(:, j), xs(j, k))
        end do
        do j = 1, nu
          yy = yy + scaled(d(:, j), uu(j))
        end do
        pa(:, :, k) = p
        do j = 1, nx
          do i = 1, ny
            call put(i, s + j, p0*p(i, j))
            call put(i, s + nx + j, -p1*p(i, j))
            call put(i, s + 2*nx + j, e*p(i, j))
          end do
        end do
      end if
      y0(:, c) = real(yy, wp)
      y0(:, c + 1) = aimag(yy)
    end do

  contains

    !> bas's element of output i and term j at this frequency (columns c, c + 1).
    subroutine put(i, j, z)
      integer, intent(in) :: i, j
      complex(wp), intent(in) :: z
      bas(i, c, j) = real(z, wp)
      bas(i, c + 1, j) = aimag(z)
    end subroutine put

  end subroutine model_terms

  !> dy (ny, nc, nf): the sensitivities of the left-hand sides to the free
  !> parameters at the transient terms eta.  Output error: X = xs + A^-1 N
  !> eta, V = U + K X, P = He A^-1 (pa); dY/dF_ij = P(:, i) X_j, dY/dG_ij =
  !> P(:, i) V_j, dY/dH_ij = e_i X_j, dY/dD_ij = e_i V_j.  Equation error: X
  !> measured, the state rows' dY/dF_kj = X_j, dY/dG_kj = V_j, the others'
  !> as output error's H, D.
  subroutine sensitivities(m, theta, pm, tf, uf, ee, xout, ainv, pa, xs, eta, dy)
    type(linear_model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), tf(:), uf(:, :), eta(:)
    type(param_map_t), intent(in) :: pm
    logical, intent(in) :: ee
    integer, intent(in) :: xout(:)
    complex(wp), intent(in) :: ainv(:, :, :), pa(:, :, :), xs(:, :)
    real(wp), intent(out) :: dy(:, :, :)
    real(wp) :: f(m%nx, m%nx), g(m%nx, m%nu), h(m%ny, m%nx), d(m%ny, m%nu), kf(m%nu, m%nx)
    complex(wp) :: x(m%nx), v(m%nu), z(m%nx), dz, p0, p1, e
    integer :: blk(size(pm%im)), row(size(pm%im)), col(size(pm%im))
    integer :: c, k, q, i, j, l, ie, ne, s, nx, nu, ny, r

    nx = m%nx
    nu = m%nu
    ny = m%ny
    call m%matrices(theta, f, g, h, d, kf)
    do q = 1, size(pm%im)
      call element(pm%im(q), blk(q), row(q), col(q))
    end do
    ie = size(uf, 1) - NEXTRA
    ne = 3*nx + 2*ny
    dy = 0.0_wp
    do c = 1, size(tf), 2
      k = (c + 1)/2
      x = xs(:, k)
      if (.not. ee) then        ! the states' transient part, A^-1 N eta
        p0 = cmplx(uf(ie + 1, c), uf(ie + 1, c + 1), wp)
        p1 = cmplx(uf(ie + 2, c), uf(ie + 2, c + 1), wp)
        e = (p0 - p1)/(IU*tf(c))
        s = (nint(uf(ie + 4, c)) - 1)*ne
        z = p0*eta(s + 1:s + nx) - p1*eta(s + nx + 1:s + 2*nx) + e*eta(s + 2*nx + 1:s + 3*nx)
        do j = 1, nx
          x = x + ainv(:, j, k)*z(j)
        end do
      end if
      v = cmplx(uf(1:nu, c), uf(1:nu, c + 1), wp)
      do j = 1, nx
        v = v + scaled(kf(:, j), x(j))
      end do
      do q = 1, size(pm%im)                 ! each moving entry into its free column
        i = row(q)
        j = col(q)
        r = pm%cm(q)
        select case (blk(q))
        case (1, 2)                         ! F(i, j), G(i, j): X_j or V_j
          if (blk(q) == 1) then
            dz = x(j)
          else
            dz = v(j)
          end if
          if (ee) then
            dy(xout(i), c, r) = dy(xout(i), c, r) + pm%wm(q)*real(dz, wp)
            dy(xout(i), c + 1, r) = dy(xout(i), c + 1, r) + pm%wm(q)*aimag(dz)
          else
            dz = pm%wm(q)*dz
            do l = 1, ny
              dy(l, c, r) = dy(l, c, r) + (real(pa(l, i, k), wp)*real(dz, wp) - &
                                           aimag(pa(l, i, k))*aimag(dz))
              dy(l, c + 1, r) = dy(l, c + 1, r) + (real(pa(l, i, k), wp)*aimag(dz) + &
                                                   aimag(pa(l, i, k))*real(dz, wp))
            end do
          end if
        case (3, 4)                         ! H(i, j), D(i, j): e_i X_j or e_i V_j
          if (blk(q) == 3) then
            dz = x(j)
          else
            dz = v(j)
          end if
          dy(i, c, r) = dy(i, c, r) + pm%wm(q)*real(dz, wp)
          dy(i, c + 1, r) = dy(i, c + 1, r) + pm%wm(q)*aimag(dz)
        end select
      end do
    end do

  contains

    !> Block (1 F, 2 G, 3 H, 4 D), row and column of p entry e.
    subroutine element(e, blk, i, j)
      integer, intent(in) :: e
      integer, intent(out) :: blk, i, j
      integer :: off(4), nr(4), q
      off = [m%of, m%og, m%oh, m%od]
      nr = [nx, nx, ny, ny]
      blk = count(e > off)
      q = e - off(blk) - 1
      i = mod(q, nr(blk)) + 1
      j = q/nr(blk) + 1
    end subroutine element

  end subroutine sensitivities

  !> r z, as r (r + 0 i) z is, without the complex product that promoting r
  !> to complex makes (the zeros' terms are exact zeros).
  elemental function scaled(r, z) result(y)
    real(wp), intent(in) :: r
    complex(wp), intent(in) :: z
    complex(wp) :: y
    y = cmplx(r*real(z, wp), r*aimag(z), wp)
  end function scaled

  !> |Re z| + |Im z|, within a factor sqrt(2) of |z|: enough to choose
  !> pivots and to scale, without abs's hypot (model_terms' largest cost).
  elemental function mag(z) result(r)
    complex(wp), intent(in) :: z
    real(wp) :: r
    r = abs(real(z, wp)) + abs(aimag(z))
  end function mag

  !> ainv = a^-1 by Gauss-Jordan elimination with partial pivoting (a is
  !> small: the model's states; scalar loops, as array operations on rows
  !> this short cost more in their set-up than in their arithmetic); ok
  !> false when a pivot vanishes (below 1e-14 big, big = max(1, max
  !> mag(a_ij)), the caller's; sizes by mag).
  pure subroutine complex_inverse(a, big, ainv, ok)
    complex(wp), intent(in) :: a(:, :)
    real(wp), intent(in) :: big
    complex(wp), intent(out) :: ainv(:, :)
    logical, intent(out) :: ok
    complex(wp) :: w(size(a, 1), size(a, 1)), f
    real(wp) :: best
    integer :: n, k, piv, i, j

    n = size(a, 1)
    w = a
    ainv = 0.0_wp
    do i = 1, n
      ainv(i, i) = 1.0_wp
    end do
    ok = .false.
    do k = 1, n
      piv = k
      best = mag(w(k, k))
      do i = k + 1, n
        if (mag(w(i, k)) > best) then
          piv = i
          best = mag(w(i, k))
        end if
      end do
      if (.not. best > 1.0e-14_wp*big) return
      if (piv /= k) then       ! w's columns before k are done (unit vectors)
        call swap(w(k, k:), w(piv, k:))
        call swap(ainv(k, :), ainv(piv, :))
      end if
      f = 1.0_wp/w(k, k)
      w(k, k + 1:) = w(k, k + 1:)*f
      ainv(k, :) = ainv(k, :)*f
      do i = 1, n
        if (i == k) cycle
        f = w(i, k)
        do j = k + 1, n
          w(i, j) = w(i, j) - f*w(k, j)
        end do
        do j = 1, n
          ainv(i, j) = ainv(i, j) - f*ainv(k, j)
        end do
      end do
    end do
    ok = .true.

  contains

    pure subroutine swap(x, y)
      complex(wp), intent(inout) :: x(:), y(:)
      complex(wp) :: t(size(x))
      t = x
      x = y
      y = t
    end subroutine swap

  end subroutine complex_inverse

end module mlid_frequency
