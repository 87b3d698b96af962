!> What model-structure determination for an equation-error model
!> y = X theta + e shares (Klein and Morelli 2006, sec. 5.4): the settings,
!> the result with its selection path, the scaled cross products and the
!> sweep that adds or removes a term, the partial F ratios, the predicted
!> square error and the final least-squares fit of the chosen terms.
!>
!> Cross products: w = [x(:, j)/|x(:, j)|, y/|y|], a = w'w (unit diagonal,
!> so the sweep's pivots compare alike).  After the terms S are swept in,
!> for k in S a(k, k) = -[(X_S'X_S)^-1]_kk and a(k, y) = theta_k (scaled);
!> for j not in S a(j, j) is the squared norm of x_j orthogonalised on S
!> and a(j, y) its product with y; a(y, y) is the residual sum of squares
!> (scaled).  With p terms in the model and N samples:
!>   F to enter j  = r_j / ((SSE - r_j)/(N - p - 1)),  r_j = a(j, y)^2/a(j, j)
!>   F to remove k = i_k / (SSE/(N - p)),              i_k = a(k, y)^2/|a(k, k)|
!>   PSE = SSE/N + sig2_max p/N  (Morelli; sig2_max = (1/N) sum (y - ybar)^2
!>         unless given), R^2 = 1 - SSE / sum (y - ybar)^2.
module mlid_regression
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT, MLID_ERR_MEMORY, MLID_ERR_INTERNAL
  use mlid_text, only: itoa, es_text
  use mlid_linalg, only: add_syrk, qr_least_squares
  implicit none
  private
  public :: regression_settings_t, regression_t, regression_check, cross_products, sweep, &
            f_enter, f_remove, path_start, path_add, regression_finish, TOL

  !> A candidate enters only while its part not explained by the model's
  !> terms keeps more than TOL of its squared norm (1 - R^2 of it on them).
  real(wp), parameter :: TOL = 1.0e-9_wp

  !> The settings: partial-F thresholds to enter and to stay, and the
  !> sig2_max of PSE (0: (1/N) sum (y - ybar)^2).
  type :: regression_settings_t
    real(wp) :: f_in = 4.0_wp
    real(wp) :: f_out = 4.0_wp
    real(wp) :: sig2_max = 0.0_wp
  end type regression_settings_t

  !> The selected model and how it was reached.  Per candidate: selected,
  !> theta and sigma (0 where not selected), f (to remove where selected,
  !> to enter where not).  The fit: r2, s (fit error, sqrt(SSE/(N - p))),
  !> pse.  The path, step 0 the start: term (+j entered, -j removed, 0 the
  !> start) and after it f (the step's partial F), r2, pse, s, np (terms).
  type :: regression_t
    logical, allocatable :: selected(:)
    real(wp), allocatable :: theta(:), sigma(:), f(:)
    real(wp) :: r2 = 0.0_wp, s = 0.0_wp, pse = 0.0_wp, sig2_max = 0.0_wp
    integer :: nsteps = 0
    integer, allocatable :: term(:), np(:)
    real(wp), allocatable :: path_f(:), path_r2(:), path_pse(:), path_s(:)
  end type regression_t

contains

  !> x (N, m) the candidates, y (N) the measured coefficient, forced (m)
  !> the terms always in the model: finite, sizes agreeing, N above the
  !> forced terms; the thresholds the procedure uses (entering: F_in and
  !> F_out, with F_out <= F_in, else a term could enter and leave for
  !> ever; removing: F_out) > 0 and finite.
  subroutine regression_check(x, y, forced, s, entering, removing, status, msg)
    real(wp), intent(in) :: x(:, :), y(:)
    logical, intent(in) :: forced(:)
    type(regression_settings_t), intent(in) :: s
    logical, intent(in) :: entering, removing
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: j
    status = MLID_ERR_INPUT
    if (size(x, 2) < 1) then
      msg = 'model structure: no candidate regressors'
    else if (size(x, 1) /= size(y) .or. size(forced) /= size(x, 2)) then
      msg = 'model structure: '//itoa(size(x, 1))//' samples of the candidates, '// &
            itoa(size(y))//' measurements, '//itoa(size(forced))//' forced flags for '// &
            itoa(size(x, 2))//' candidates'
    else if (size(y) <= count(forced) + 1) then
      msg = 'model structure: '//itoa(size(y))//' samples are too few for '// &
            itoa(count(forced))//' forced terms and one more'
    else if (.not. (all(ieee_is_finite(x)) .and. all(ieee_is_finite(y)))) then
      msg = 'model structure: the candidates and the measurements must be finite'
    else if (entering .and. .not. (s%f_in > 0.0_wp .and. s%f_out > 0.0_wp .and. &
                                   s%f_out <= s%f_in .and. ieee_is_finite(s%f_in))) then
      msg = 'model structure: F_in and F_out must be > 0 and finite with F_out <= F_in, not '// &
            trim(adjustl(es_text(s%f_in, 10, 3)))//' and '//trim(adjustl(es_text(s%f_out, 10, 3)))
    else if (removing .and. .not. (s%f_out > 0.0_wp .and. ieee_is_finite(s%f_out))) then
      msg = 'model structure: F_out must be > 0 and finite, not '// &
            trim(adjustl(es_text(s%f_out, 10, 3)))
    else if (.not. (s%sig2_max >= 0.0_wp .and. ieee_is_finite(s%sig2_max))) then
      msg = 'model structure: sig2_max must be >= 0 (0: the variance of y) and finite'
    else
      do j = 1, size(x, 2)
        if (all(x(:, j) == 0.0_wp)) then
          msg = 'model structure: candidate '//itoa(j)//' is zero throughout'
          return
        end if
      end do
      if (maxval(y) == minval(y)) then
        msg = 'model structure: the measurements are constant throughout: nothing to model'
        return
      end if
      status = MLID_OK
      msg = ''
    end if
  end subroutine regression_check

  !> a = w'w of the unit-norm columns w = [x/|x_j|, y/|y|] ((m + 1)^2).
  subroutine cross_products(x, y, a, status, msg)
    real(wp), intent(in) :: x(:, :), y(:)
    real(wp), intent(out) :: a(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), allocatable :: w(:, :)
    integer :: j, m, ierr
    m = size(x, 2)
    allocate (w(size(y), m + 1), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'model structure: out of memory for '//itoa(size(y))//' x '//itoa(m + 1)//' values'
      return
    end if
    do j = 1, m
      w(:, j) = x(:, j)/norm2(x(:, j))
    end do
    w(:, m + 1) = y/norm2(y)
    a = 0.0_wp
    call add_syrk(size(y), m + 1, w, a)
    status = MLID_OK
    msg = ''
  end subroutine cross_products

  !> Sweep term k into the model (into) or out of it (the reverse sweep):
  !> each undoes the other.
  pure subroutine sweep(a, k, into)
    real(wp), intent(inout) :: a(:, :)
    integer, intent(in) :: k
    logical, intent(in) :: into
    real(wp) :: d, c(size(a, 1))
    integer :: i, j
    d = a(k, k)
    c = a(:, k)
    do j = 1, size(a, 1)
      if (j == k) cycle
      do i = 1, size(a, 1)
        if (i /= k) a(i, j) = a(i, j) - c(i)*c(j)/d
      end do
    end do
    if (into) then
      c = c/d
    else
      c = -c/d
    end if
    a(:, k) = c
    a(k, :) = c
    a(k, k) = -1.0_wp/d
  end subroutine sweep

  !> Partial F of candidate j (out of the model of np terms) to enter; 0
  !> where it is (nearly) a combination of the model's terms.
  pure real(wp) function f_enter(a, j, np, n) result(f)
    real(wp), intent(in) :: a(:, :)
    integer, intent(in) :: j, np, n
    real(wp) :: r, sse
    integer :: ny
    ny = size(a, 1)
    f = 0.0_wp
    if (a(j, j) <= TOL .or. n - np - 1 < 1) return
    r = a(j, ny)**2/a(j, j)
    sse = max(a(ny, ny) - r, 0.0_wp)
    if (sse > 0.0_wp) then
      f = r/(sse/(n - np - 1))
    else
      f = huge(1.0_wp)
    end if
  end function f_enter

  !> Partial F of term k (in the model of np terms) to remove.
  pure real(wp) function f_remove(a, k, np, n) result(f)
    real(wp), intent(in) :: a(:, :)
    integer, intent(in) :: k, np, n
    integer :: ny
    ny = size(a, 1)
    if (a(ny, ny) > 0.0_wp) then
      f = (a(k, ny)**2/abs(a(k, k)))/(a(ny, ny)/(n - np))
    else
      f = huge(1.0_wp)
    end if
  end function f_remove

  !> The result's arrays for m candidates and up to maxsteps steps, and the
  !> path's start: the model of np terms with residual sum of squares sse.
  subroutine path_start(r, m, maxsteps, y, s, np, sse, status, msg)
    type(regression_t), intent(out) :: r
    integer, intent(in) :: m, maxsteps, np
    real(wp), intent(in) :: y(:), sse
    type(regression_settings_t), intent(in) :: s
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: ierr
    allocate (r%selected(m), r%theta(m), r%sigma(m), r%f(m), r%term(0:maxsteps), &
              r%np(0:maxsteps), r%path_f(0:maxsteps), r%path_r2(0:maxsteps), &
              r%path_pse(0:maxsteps), r%path_s(0:maxsteps), stat=ierr)
    if (ierr /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'model structure: out of memory for the path'
      return
    end if
    r%selected = .false.
    r%theta = 0.0_wp
    r%sigma = 0.0_wp
    r%f = 0.0_wp
    r%sig2_max = s%sig2_max
    if (r%sig2_max == 0.0_wp) r%sig2_max = sum((y - sum(y)/size(y))**2)/size(y)
    r%nsteps = -1
    call path_add(r, 0, 0.0_wp, y, np, sse, status, msg)
  end subroutine path_start

  !> One step of the path: term (+j in, -j out), its F, and the model of np
  !> terms after it with residual sum of squares sse (unscaled).
  subroutine path_add(r, term, f, y, np, sse, status, msg)
    type(regression_t), intent(inout) :: r
    integer, intent(in) :: term, np
    real(wp), intent(in) :: f, y(:), sse
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: k, n
    n = size(y)
    k = r%nsteps + 1
    if (k > ubound(r%term, 1)) then
      status = MLID_ERR_INTERNAL
      msg = 'model structure: the selection did not settle in '//itoa(k)//' steps'
      return
    end if
    r%nsteps = k
    r%term(k) = term
    r%np(k) = np
    r%path_f(k) = f
    r%path_r2(k) = 1.0_wp - sse/sum((y - sum(y)/n)**2)
    r%path_pse(k) = sse/n + r%sig2_max*np/n
    r%path_s(k) = sqrt(sse/max(n - np, 1))
    status = MLID_OK
    msg = ''
  end subroutine path_add

  !> The final model of the terms in (a logical mask): theta and sigma by
  !> least squares on the unscaled candidates (QR), its r2, s and pse, and
  !> each candidate's partial F (to remove or to enter) from a, the scaled
  !> cross products with exactly those terms swept in.
  subroutine regression_finish(x, y, in, a, r, status, msg)
    real(wp), intent(in) :: x(:, :), y(:), a(:, :)
    logical, intent(in) :: in(:)
    type(regression_t), intent(inout) :: r
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer, allocatable :: idx(:)
    real(wp), allocatable :: th(:), cd(:), e(:)
    real(wp) :: sse
    integer :: j, n, np, info
    n = size(y)
    idx = pack([(j, j=1, size(in))], in)
    np = size(idx)
    r%selected = in
    r%theta = 0.0_wp
    r%sigma = 0.0_wp
    allocate (th(np), cd(np), stat=info)
    if (info /= 0) then
      status = MLID_ERR_MEMORY
      msg = 'model structure: out of memory'
      return
    end if
    call qr_least_squares(x(:, idx), y, th, cd, info)
    if (info /= 0) then
      status = MLID_ERR_INTERNAL
      msg = 'model structure: the least-squares fit of the selected terms failed (LAPACK '// &
            itoa(info)//')'
      return
    end if
    e = y - matmul(x(:, idx), th)
    sse = dot_product(e, e)
    r%theta(idx) = th
    r%sigma(idx) = sqrt(sse/(n - np)*cd)
    r%r2 = 1.0_wp - sse/sum((y - sum(y)/n)**2)
    r%s = sqrt(sse/(n - np))
    r%pse = sse/n + r%sig2_max*np/n
    do j = 1, size(in)
      if (in(j)) then
        r%f(j) = f_remove(a, j, np, n)
      else
        r%f(j) = f_enter(a, j, np, n)
      end if
    end do
    status = MLID_OK
    msg = ''
  end subroutine regression_finish

end module mlid_regression
