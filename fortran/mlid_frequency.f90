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
!> below it) and in its last row the weight c_k, y the measured left-hand
!> sides Y (equation error: i w Y for the outputs that measure a state).
!>
!> What the frequency domain leaves out: each channel's mean over the
!> manoeuvre is removed before the transform, so constant biases and trim
!> values drop out exactly (x0, output biases and the state biases bx are
!> not parameters here); slow drifts and the initial and final states enter
!> only through the transform's leakage, which falls as 1/w away from zero:
!> choose f_min a few times 1/T above them.  Free x0, biases, noise
!> statistics, delays, Gamma, K or bx are refused with a message.
module mlid_frequency
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_SINGULAR
  use mlid_models, only: model_t, linear_model_t
  use mlid_options, only: options_t, METHOD_FREQ_EE
  use mlid_params, only: param_map_t, input_delays, output_delays, stabilized
  use mlid_fourier, only: fourier_transform
  use mlid_linalg, only: chol_inverse
  use mlid_text, only: itoa
  implicit none
  private
  public :: freq_record, freq_likelihood, freq_grid

  real(wp), parameter :: TWO_PI = 8.0_wp*atan(1.0_wp)
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
    integer :: xout(m%nx), nseg, nk, s, j0, j1, k, c, i, nu, ny
    real(wp) :: dt

    call freq_check(m, theta, pm, opt, xout, status, msg)
    if (status /= MLID_OK) return
    nu = m%nu
    ny = m%ny
    nseg = pm%l%nseg
    nk = opt%n_freq
    w = TWO_PI*freq_grid(opt)
    allocate (tf(2*nk*nseg), uf(nu + merge(m%nx, 0, opt%method == METHOD_FREQ_EE) + 1, &
              2*nk*nseg), yf(ny, 2*nk*nseg))
    status = MLID_ERR_INPUT
    do s = 1, nseg
      j0 = pm%l%seg(s)
      j1 = size(t)
      if (s < nseg) j1 = pm%l%seg(s + 1) - 1
      if (j1 - j0 < 2) then
        msg = 'manoeuvre '//itoa(s)//' has fewer than three samples to transform'
        return
      end if
      dt = (t(j1) - t(j0))/(j1 - j0)
      if (maxval(abs(t(j0 + 1:j1) - t(j0:j1 - 1) - dt)) > 1.0e-6_wp*dt) then
        msg = 'the frequency-domain methods need uniform sampling: manoeuvre '//itoa(s)// &
              ' is not uniformly sampled'
        return
      end if
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
      do k = 1, nk
        c = 2*((s - 1)*nk + k) - 1
        tf(c:c + 1) = w(k)
        uf(size(uf, 1), c:c + 1) = min(1.0_wp, (opt%f_max - opt%f_min)/(nk - 1)*(t(j1) - t(j0)))
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
    real(wp) :: h(m%ny, m%nx), d(m%ny, m%nu)
    logical :: moving(m%ny)
    integer :: i, k, e
    h = reshape(theta(m%oh + 1:m%oh + m%ny*m%nx), [m%ny, m%nx])
    d = reshape(theta(m%od + 1:m%od + m%ny*m%nu), [m%ny, m%nu])
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

  !> Cost, S-hat (rhat), the fitted left-hand sides (yhat, the layout above)
  !> and with grad and info their gradient and information at S-hat; sens,
  !> wsens, msens as mlid_likelihood's.
  subroutine freq_likelihood(m, theta, pm, tf, uf, yf, opt, cost, rhat, yhat, status, msg, grad, &
                             info, sens, wsens, msens)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), tf(:), uf(:, :), yf(:, :)
    type(param_map_t), intent(in) :: pm
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: cost, rhat(:, :), yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: grad(:), info(:, :), sens(:, :), wsens(:, :, :), msens(:, :)
    real(wp), allocatable :: dy(:, :, :), r(:, :), a(:, :), cw(:), rw(:, :)
    real(wp) :: sinv(m%ny, m%ny), logdet, n
    integer :: xout(m%nx), nc, i, f, ierr

    cost = huge(1.0_wp)
    nc = size(tf)
    status = MLID_ERR_INPUT
    if (mod(nc, 2) /= 0 .or. nc == 0) then
      msg = 'the frequency-domain likelihood takes the transformed record (mlid_frequency)'
      return
    else if (any(tf(1::2) /= tf(2::2))) then
      msg = 'the frequency-domain likelihood takes the transformed record (mlid_frequency)'
      return
    end if
    call freq_check(m, theta, pm, opt, xout, status, msg)
    if (status /= MLID_OK) return
    allocate (dy(m%ny, pm%nf, nc))
    select type (m)
    type is (linear_model_t)
      call predict(m, theta, pm, tf, uf, opt%method == METHOD_FREQ_EE, xout, yhat, dy, &
                   present(grad), status, msg)
    end select
    if (status /= MLID_OK) return
    r = yf - yhat
    cw = uf(size(uf, 1), :)                            ! each column's weight c_k
    n = 0.5_wp*sum(cw)
    rw = r*spread(cw, 1, m%ny)
    rhat = matmul(rw, transpose(r))/n                  ! S = (1/n) sum c Re(V V^*)
    if (.not. opt%full_r) then
      do i = 1, m%ny
        rhat(:i - 1, i) = 0.0_wp
        rhat(i + 1:, i) = 0.0_wp
      end do
    end if
    if (.not. all([(rhat(i, i) > tiny(1.0_wp), i=1, m%ny)])) then
      status = MLID_ERR_SINGULAR
      msg = 'a residual spectrum is zero or not finite: an output fitted exactly '// &
            '(noise-free data?)'
      return
    end if
    call chol_inverse(rhat, sinv, logdet, ierr)
    if (ierr /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'residual covariance is singular (outputs linearly dependent): use noise = ''diagonal'''
      return
    end if
    cost = sum(rw*matmul(sinv, r)) + n*logdet
    if (.not. ieee_is_finite(cost)) then
      status = MLID_ERR_SINGULAR
      msg = 'cost is not finite'
      return
    end if
    if (.not. (present(grad) .and. present(info))) return
    allocate (a(m%ny, nc))
    grad = 0.0_wp
    info = 0.0_wp
    do f = 1, pm%nf
      a = 2.0_wp*matmul(sinv, dy(:, f, :))*spread(cw, 1, m%ny)     ! 2 c S^-1 dV
      grad(f) = -sum(a*r)
      if (present(wsens)) wsens(:, :, f) = a
      do i = 1, f
        info(i, f) = sum(dy(:, i, :)*a)
        info(f, i) = info(i, f)
      end do
    end do
    if (present(msens)) msens = info
    if (present(sens)) then
      do i = 1, m%ny
        sens(i, :) = sqrt(matmul(dy(i, :, :)**2, cw)/rhat(i, i))
      end do
    end if
  end subroutine freq_likelihood

  !> yhat and its sensitivities dy (ny, nf, nc) at every frequency.  Output
  !> error: X = A^-1 G U, A = i w I - Fe, V = U + K X, Y = H X + D V; with
  !> P = He A^-1, dY/dF_ij = P(:, i) X_j, dY/dG_ij = P(:, i) V_j, dY/dH_ij
  !> = e_i X_j, dY/dD_ij = e_i V_j.  Equation error: X measured, the state
  !> rows' dY/dF_kj = X_j, dY/dG_kj = V_j, the others' as output error's H, D.
  subroutine predict(m, theta, pm, tf, uf, ee, xout, yhat, dy, want_dy, status, msg)
    type(linear_model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), tf(:), uf(:, :)
    type(param_map_t), intent(in) :: pm
    logical, intent(in) :: ee, want_dy
    integer, intent(in) :: xout(:)
    real(wp), intent(out) :: yhat(:, :), dy(:, :, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp) :: f(m%nx, m%nx), g(m%nx, m%nu), h(m%ny, m%nx), d(m%ny, m%nu), kf(m%nu, m%nx)
    complex(wp) :: a(m%nx, m%nx), ainv(m%nx, m%nx), p(m%ny, m%nx), x(m%nx), v(m%nu), &
                   uu(m%nu), yy(m%ny), dz(m%ny)
    integer :: c, k, e, blk, i, j, row(m%nx), nx, nu, ny
    logical :: ok

    nx = m%nx
    nu = m%nu
    ny = m%ny
    f = reshape(theta(m%of + 1:m%of + nx*nx), [nx, nx])
    g = reshape(theta(m%og + 1:m%og + nx*nu), [nx, nu])
    h = reshape(theta(m%oh + 1:m%oh + ny*nx), [ny, nx])
    d = reshape(theta(m%od + 1:m%od + ny*nu), [ny, nu])
    kf = reshape(theta(m%ok + 1:m%ok + nu*nx), [nu, nx])
    row = xout
    status = MLID_OK
    msg = ''
    dy = 0.0_wp
    do c = 1, size(tf), 2
      uu = cmplx(uf(1:nu, c), uf(1:nu, c + 1), wp)
      if (ee) then
        x = cmplx(uf(nu + 1:nu + nx, c), uf(nu + 1:nu + nx, c + 1), wp)
        v = uu + matmul(kf, x)
        yy = matmul(h, x) + matmul(d, v)
        yy(row) = matmul(f, x) + matmul(g, v)
      else
        a = -(f + matmul(g, kf))
        do i = 1, nx
          a(i, i) = a(i, i) + IU*tf(c)
        end do
        call complex_inverse(a, ainv, ok)
        if (.not. ok) then
          status = MLID_ERR_SINGULAR
          write (msg, '(a,g0.6,a)') 'i w I - F is singular at ', tf(c)/TWO_PI, &
            ' Hz: the model has a pole on the imaginary axis there'
          return
        end if
        x = matmul(ainv, matmul(g, uu))
        v = uu + matmul(kf, x)
        yy = matmul(h, x) + matmul(d, v)
        p = matmul(h + matmul(d, kf), ainv)
      end if
      yhat(:, c) = real(yy, wp)
      yhat(:, c + 1) = aimag(yy)
      if (.not. want_dy) cycle
      do k = 1, size(pm%im)                 ! each moving entry into its free column
        e = pm%im(k)
        call element(e, blk, i, j)
        dz = 0.0_wp
        select case (blk)
        case (1, 2)                         ! F(i, j), G(i, j): X_j or V_j
          if (ee .and. blk == 1) then
            dz(row(i)) = x(j)
          else if (ee) then
            dz(row(i)) = v(j)
          else if (blk == 1) then
            dz = p(:, i)*x(j)
          else
            dz = p(:, i)*v(j)
          end if
        case (3)                            ! H(i, j)
          dz(i) = x(j)
        case (4)                            ! D(i, j)
          dz(i) = v(j)
        end select
        dy(:, pm%cm(k), c) = dy(:, pm%cm(k), c) + pm%wm(k)*real(dz, wp)
        dy(:, pm%cm(k), c + 1) = dy(:, pm%cm(k), c + 1) + pm%wm(k)*aimag(dz)
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

  end subroutine predict

  !> ainv = a^-1 by Gauss-Jordan elimination with partial pivoting (a is
  !> small: the model's states); ok false when a pivot vanishes.
  pure subroutine complex_inverse(a, ainv, ok)
    complex(wp), intent(in) :: a(:, :)
    complex(wp), intent(out) :: ainv(:, :)
    logical, intent(out) :: ok
    complex(wp) :: w(size(a, 1), 2*size(a, 1)), tmp(2*size(a, 1))
    integer :: n, k, piv, i
    n = size(a, 1)
    w = 0.0_wp
    w(:, 1:n) = a
    do i = 1, n
      w(i, n + i) = 1.0_wp
    end do
    ok = .false.
    do k = 1, n
      piv = maxloc(abs(w(k:, k)), 1) + k - 1
      if (.not. abs(w(piv, k)) > 1.0e-14_wp*max(1.0_wp, maxval(abs(a)))) return
      tmp = w(k, :)
      w(k, :) = w(piv, :)
      w(piv, :) = tmp
      w(k, :) = w(k, :)/w(k, k)
      do i = 1, n
        if (i /= k) w(i, :) = w(i, :) - w(i, k)*w(k, :)
      end do
    end do
    ainv = w(:, n + 1:)
    ok = .true.
  end subroutine complex_inverse

end module mlid_frequency
